"""Where a trial's files live: ``<data_dir>/trials/<trial_id>/`` with a fixed set of names.

Shared by the worker (writes) and the API (serves). Names are fixed, ids validated, so a request can
never reach outside the trial's folder. Files are written to a temporary name and renamed.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

from gaitcap.services.catalog.ids import validate_id

STAGES = ("preliminary", "refined")

# artifact key -> file name inside a stage folder
STAGE_FILES = {
    "trajectory_npz": "trajectory.npz",
    "trajectory_trc": "trajectory.trc",
    "rerun_rrd": "trajectory.rrd",
    "results_mcap": "results.mcap",
    "gait_json": "gait.json",
    "steps_csv": "steps.csv",
    "summary_csv": "summary.csv",  # per-side statistics and symmetry index of every parameter
    "report_png": "report.png",
    # joint kinematics (gaitcap.services.kinematics.trial.FILES, in a subfolder)
    "kinematics_json": "kinematics/kinematics.json",
    "kinematics_csv": "kinematics/kinematics.csv",
    "kinematics_png": "kinematics/kinematics.png",
    "kinematics_mot": "kinematics/kinematics.mot",
    "kinematics_osim": "kinematics/kinematics.osim",
    "kinematics_trc": "kinematics/kinematics.trc",
    "trajectory_c3d": "kinematics/trajectory.c3d",
}


@dataclass(frozen=True)
class TrialFiles:
    """The files of one trial; ``recording_path``: where the catalog records its MCAP (None: the default
    place in the trial's folder, where the API puts new trials)."""

    root: Path
    recording_path: Path | None = None

    @property
    def recording(self) -> Path:
        """The trial's MCAP (frames, keypoints, calibration, metadata)."""
        return self.recording_path or self.root / "recording.mcap"

    @property
    def people_json(self) -> Path:
        """Everyone tracked in the trial and which track is the patient (written by the worker)."""
        return self.root / "people.json"

    @property
    def tracks_npz(self) -> Path:
        """The tracks themselves (which detection is whose), to resolve a click on a camera image."""
        return self.root / "tracks.npz"

    @property
    def checks_json(self) -> Path:
        """The trial's checks of its results (one person, the rig; written once every stage is stored)."""
        return self.root / "checks.json"

    @property
    def rig_keypoints_npz(self) -> Path:
        """The patient's 2D keypoints the rig check judged (its frames only): the baseline of the rig
        checks of later trials under the same calibration (written by the one processing path)."""
        return self.root / "rig_keypoints.npz"

    @property
    def patient_choice_json(self) -> Path:
        """The clinician's choice of the patient's track (written by the API; wins over automatic)."""
        return self.root / "patient_choice.json"

    def stage_file(self, stage: str, key: str) -> Path:
        if stage not in STAGES:
            raise ValueError(f"stage: must be one of {STAGES}, got {stage!r}")
        if key not in STAGE_FILES:
            raise ValueError(f"artifact: must be one of {sorted(STAGE_FILES)}, got {key!r}")
        return self.root / stage / STAGE_FILES[key]

    def existing(self, stage: str) -> dict[str, str]:
        """artifact key -> path of the files of ``stage`` that exist."""
        return {k: str(self.stage_file(stage, k)) for k in STAGE_FILES if self.stage_file(stage, k).exists()}


def trial_files(data_dir: str | Path, trial_id: str, recording_path: str | Path | None = None) -> TrialFiles:
    """The trial's files; pass the catalog's ``recording_path`` wherever the trial's record is at hand."""
    validate_id(trial_id, field="trial_id")
    return TrialFiles(Path(data_dir) / "trials" / trial_id, Path(recording_path) if recording_path else None)




def remove_trial_files(files: TrialFiles) -> list[Path]:
    """Delete the trial's folder and its recording (wherever the catalog put it, with a ``.part`` left by a
    crash); returns what could not be removed (empty when everything is gone)."""
    shutil.rmtree(files.root, ignore_errors=True)
    recording = files.recording
    for path in (recording, recording.with_name(recording.name + ".part")):
        try:
            path.unlink(missing_ok=True)
        except OSError:
            pass
    return [p for p in (files.root, recording, recording.with_name(recording.name + ".part")) if p.exists()]
