"""Real Plug-in-Gait walks (C3D: markers, events, the lab's Plug-in-Gait joint angles) as the rig sees them.

The walks of ``../shared/data/c3d/`` (see its README) are read with ezc3d and turned into a
:class:`~gaitcap.simulator.mocap.MocapWalk` whose Halpe-26 joints are the keypoints a detector would give:
- hips, knees, ankles: Plug-in-Gait's joint centres (``LFEP`` hip, ``LFEO`` knee, ``LTIO`` ankle: the
  femur's proximal end and origin, the tibia's origin), as a detector's hip, knee and ankle estimate the
  joints, not skin markers;
- heel and big toe: the ``LHEE`` and ``LTOE`` markers (``LTOE`` lies on the second metatarsal head, about
  50 mm behind a detector's big-toe tip: see docs/kinematics.md);
- small toe: beside the big toe, :data:`SMALL_TOE_LATERAL_MM` lateral and :data:`SMALL_TOE_BACK_MM` back
  along the foot, in the foot's own frame (heel -> toe, up towards the ankle joint centre): it turns with
  the foot, as a detector's small toe does. Not in Plug-in-Gait's foot frame (``LFOO``/``LFOL``): its
  lateral axis is the tibia's ankle axis, so a small toe placed there rolled with the shank (10-16 mm up and
  down against the heel, toe and ankle on these walks; docs/kinematics.md);
- shoulders: ``LSHO``/``RSHO`` where the walk has them; the rest of the upper body as ``mocap`` places it.
The file is read by the validation's C3D reader (``acquisition.references.c3d.open_c3d``: gaps NaN).
Markers are resampled (linearly) to :data:`RATE_HZ` so that the rig's 30 fps divides the rate; the angles
stay on the file's own clock. Event times are the EVENT group's minus the trial's start
((ACTUAL_START_FIELD - 1) / rate).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from gaitcap.acquisition.references.c3d import c3d_events, open_c3d
from gaitcap.reconstruction.kinematics.foot import foot_frames
from gaitcap.simulator.mocap import SIDES, MocapWalk, _screen, _to_room

RATE_HZ = 120.0
# the team's shared data beside the checkout (an editable install keeps simulator/ in the checkout)
C3D_DIR = Path(os.environ.get("GAITCAP_C3D_DIR")
               or Path(__file__).resolve().parents[1].parent / "shared" / "data" / "c3d")
C3D_WALKS = ("FunctionalWalk", "PiG_Motion3_FF", "PiG_Motion-FlatFoot-Full")
SMALL_TOE_LATERAL_MM = 35.0
SMALL_TOE_BACK_MM = 20.0
# Plug-in-Gait output -> the walk's marker (per side letter L / R)
JOINT_CENTRES = {"hip": "FEP", "knee": "FEO", "ankle": "TIO", "heel": "HEE", "toe": "TOE"}
ANGLES = {"hip_flexion": "HipAngles", "knee_flexion": "KneeAngles", "ankle_dorsiflexion": "AnkleAngles"}


@dataclass(frozen=True, eq=False)
class PigWalk:
    """A real walk and its laboratory's Plug-in-Gait angles.

    Attributes:
        walk: the walk (room frame, mm, :data:`RATE_HZ`), with the screened Foot Strike / Foot Off events.
        angle_times_s: (N,) the file's own frame times (s, from the first frame).
        angles_deg: variable (``hip_flexion``, ``knee_flexion``, ``ankle_dorsiflexion``) -> side -> (N,)
            degrees, Plug-in-Gait's (flexion and dorsiflexion positive).
        file: the C3D's name.
    """

    walk: MocapWalk
    angle_times_s: np.ndarray
    angles_deg: dict[str, dict[str, np.ndarray]]
    file: str

    def angles_at(self, times_s: np.ndarray) -> dict[str, dict[str, np.ndarray]]:
        """The angles interpolated at ``times_s`` (s, the walk's clock; NaN outside the file)."""
        return {v: {s: np.interp(times_s, self.angle_times_s, a, left=np.nan, right=np.nan) for s, a in by.items()}
                for v, by in self.angles_deg.items()}


def _small_toe(side: str, ankle: np.ndarray, heel: np.ndarray, toe: np.ndarray) -> np.ndarray:
    """(T, 3) the small toe beside ``toe`` in the foot's own frame (``foot.foot_frames``: x heel -> toe, y up
    towards the ankle, z = x cross y, to the right in the C3D's right-handed, z-up lab frame)."""
    axes = foot_frames(ankle, heel, toe)
    lateral = axes[:, 2] if side == "right" else -axes[:, 2]
    return toe + SMALL_TOE_LATERAL_MM * lateral - SMALL_TOE_BACK_MM * axes[:, 0]


def _resample(times_s: np.ndarray, p: np.ndarray, new_times_s: np.ndarray) -> np.ndarray:
    return np.stack([np.interp(new_times_s, times_s, p[:, k]) for k in range(p.shape[1])], axis=1)


def load_pig_walk(path: Path) -> PigWalk:
    """Read one Plug-in-Gait walk (see the module docstring). ValueError naming the file and what it lacks."""
    path = Path(path)
    c3d = open_c3d(path)
    rate, times = c3d.rate_hz, c3d.times_s
    raw: dict[str, np.ndarray] = {}
    try:
        for side in SIDES:
            letter = side[0].upper()
            for part, pig in JOINT_CENTRES.items():
                raw[f"{side}_{part}"] = c3d.marker_mm(f"{letter}{pig}")
            raw[f"{side}_small_toe"] = _small_toe(side, raw[f"{side}_ankle"], raw[f"{side}_heel"], raw[f"{side}_toe"])
            if f"{letter}SHO" in c3d.labels:
                raw[f"{side}_shoulder"] = c3d.marker_mm(f"{letter}SHO")
        angles = {v: {s: c3d.raw(f"{s[0].upper()}{pig}")[:, 0] for s in SIDES}
                  for v, pig in ANGLES.items()}
    except KeyError as exc:
        raise ValueError(f"{path.name}: {exc.args[0]} (a Plug-in-Gait walk needs its joint centres, heel and toe "
                         "markers and angles)") from None
    whole = np.all([np.isfinite(p).all(axis=1) for k, p in raw.items() if not k.endswith("shoulder")], axis=0)
    shoulders = [k for k in raw if k.endswith("shoulder")]
    if len(shoulders) != 2 or not all(np.isfinite(raw[k][whole]).all() for k in shoulders):
        raw = {k: v for k, v in raw.items() if k not in shoulders}  # the upper body placed as mocap does
    if whole.sum() < rate:
        raise ValueError(f"{path.name}: only {int(whole.sum())} frames have every joint centre and foot marker")
    first, last = np.nonzero(whole)[0][[0, -1]]
    new_times = np.arange(times[first], times[last] + 1e-9, 1.0 / RATE_HZ)
    markers = _to_room({k: _resample(times[first:last + 1], p[first:last + 1], new_times) for k, p in raw.items()})
    annotated = c3d_events(c3d.params, c3d.start_s, path.name)
    events = {kind: {s: [] if by is None else sorted(map(float, by[s])) for s in SIDES}
              for kind, by in zip(("heel_strike", "toe_off"), annotated, strict=True)}
    hs, to, excluded = _screen(markers, new_times, events)
    walk = MocapWalk(path.stem, f"{path.name} (Plug-in-Gait, {rate:g} Hz)", RATE_HZ, new_times, markers, hs, to,
                     excluded)
    return PigWalk(walk, times, angles, path.name)


def available_pig_walks(directory: Path | None = None) -> list[str]:
    """Names of the walks of ``C3D_WALKS`` found in ``directory`` (default ``C3D_DIR``, or
    ``$GAITCAP_C3D_DIR``)."""
    return [name for name in C3D_WALKS if ((directory or C3D_DIR) / f"{name}.c3d").is_file()]
