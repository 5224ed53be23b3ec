"""The synthetic gait world: a walking patient with exact ground truth, seen by a simulated camera rig.

    from gaitcap.simulator import make_trial, SyntheticTrial, WalkParams, PRESETS
    trial = make_trial(preset="paper", seconds=30.0, cameras=10, people=1, seed=0, fps=30.0)

Units: world mm (z up, floor z = 0, origin at the centre of the 7.4 m x 8 m room), pixels px, times s
(clock offsets/jitter ns). Joints follow Halpe-26 (``gaitcap.reconstruction.skeletons``). Everything is
deterministic given the arguments. Modules: ``params`` (WalkParams), ``path`` (room, footstep plan),
``walker`` (kinematic body), ``truth`` (gait events and step parameters), ``room`` (camera rig),
``noise`` (detector model and PRESETS), ``people`` (therapist, bystander), ``trial`` (make_trial),
``render`` (images), ``files`` (simulate outputs on disk).
"""

from gaitcap.simulator.noise import PRESETS, NoisePreset
from gaitcap.simulator.params import WalkParams
from gaitcap.simulator.trial import SyntheticPeople, SyntheticTrial, make_trial
from gaitcap.simulator.truth import GaitTruth, StepTable

__all__ = [
    "PRESETS", "NoisePreset", "WalkParams", "make_trial", "SyntheticTrial", "SyntheticPeople", "GaitTruth",
    "StepTable", "save_trial", "load_trial_files",
]


def __getattr__(name):  # lazy: files pulls in the calibration writer
    if name in ("save_trial", "load_trial_files", "SimulationFiles"):
        from gaitcap.simulator import files

        return getattr(files, name)
    raise AttributeError(name)
