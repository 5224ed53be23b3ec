"""A reference recording of a walk (marker system, instrumented walkway) as gaitcap compares with it.

Markers are mapped to gaitcap's joint names (``JOINT_LABELS``: the first label present wins); the reference
clock starts at its first frame (0 s). Events are per side (``left``/``right``) in s on that clock.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from gaitcap.reconstruction.gait.walkway import WalkwayTrial

SIDES = ("left", "right")
_PREFIX = {"left": "L", "right": "R"}
# gaitcap joint -> labels that stand for it, first present wins (``{s}``: L/R): joint centres where the
# model outputs them (Plug-in-Gait: the femur's proximal point ``FEP`` is the hip joint centre, the femur's
# origin ``FEO`` the knee's, the tibia's origin ``TIO`` the ankle's), else the skin markers.
JOINT_LABELS = {
    "heel": ("{s}HEE", "{s}_HEEL", "{s}Heel"),
    "ankle": ("{s}AJC", "{s}TIO", "{s}ANK", "{s}_ANKLE", "{s}Ankle"),
    "knee": ("{s}KJC", "{s}FEO", "{s}KNE", "{s}_KNEE", "{s}Knee"),
    "hip": ("{s}HJC", "{s}FEP", "{side}HipCenter", "{s}_HIP", "{s}Hip"),
    "big_toe": ("{s}TOE", "{s}_TOE", "{s}Toe"),
}
#: joints whose markers the rigid fit uses (both sides)
FIT_JOINTS = ("heel", "ankle", "hip")
# clinical variable -> (model output label stem, component): Plug-in-Gait angles, degrees, flexion,
# adduction, internal rotation and dorsiflexion positive (the signs of gaitcap's clinical angles).
ANGLE_LABELS = {
    "pelvis_obliquity": ("PelvisAngles", 1),
    "pelvis_rotation": ("PelvisAngles", 2),
    "hip_flexion": ("HipAngles", 0),
    "hip_adduction": ("HipAngles", 1),
    "hip_rotation": ("HipAngles", 2),
    "knee_flexion": ("KneeAngles", 0),
    "ankle_dorsiflexion": ("AnkleAngles", 0),
}


@dataclass(frozen=True, eq=False)
class Reference:
    """What a reference file holds, on its own clock and in its own frame.

    Attributes:
        source: the file (for messages).
        kind: "C3D", "TRC" or "walkway CSV".
        times_s: (T,) marker times (s, 0 at the first frame); empty for a walkway.
        joints_mm: gaitcap joint name (``left_heel`` ...) -> (T, 3) marker (mm, NaN where missing).
        labels: gaitcap joint name -> the marker label it came from.
        heel_strike_s, toe_off_s: side -> (K,) events (s); None when the file holds no events.
        angles_deg: clinical variable -> side -> (T,) model output angle (degrees).
        walkway: the footfalls of a walkway export (else None).
        lacks: what the file does not hold, in words (said in the report).
    """

    source: str
    kind: str
    times_s: np.ndarray
    joints_mm: dict[str, np.ndarray]
    labels: dict[str, str]
    heel_strike_s: dict[str, np.ndarray] | None = None
    toe_off_s: dict[str, np.ndarray] | None = None
    angles_deg: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    walkway: WalkwayTrial | None = None
    lacks: tuple[str, ...] = ()

    @property
    def rate_hz(self) -> float:
        return float((len(self.times_s) - 1) / (self.times_s[-1] - self.times_s[0])) if len(self.times_s) > 1 else 0.0

    @property
    def has_events(self) -> bool:
        return self.heel_strike_s is not None and any(len(v) for v in self.heel_strike_s.values())


def map_markers(points_mm: dict[str, np.ndarray]) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """Reference markers (label -> (T, 3) mm) -> (gaitcap joint -> (T, 3), joint -> label used).
    A marker that is never finite counts as absent."""
    joints, labels = {}, {}
    for side in SIDES:
        for joint, candidates in JOINT_LABELS.items():
            for pattern in (f"{side}_{joint}", *candidates):  # gaitcap's own names first (its TRC)
                label = pattern.format(s=_PREFIX[side], side=side.capitalize())
                p = points_mm.get(label)
                if p is not None and np.isfinite(p).all(axis=1).any():
                    joints[f"{side}_{joint}"], labels[f"{side}_{joint}"] = np.asarray(p, dtype=np.float64), label
                    break
    return joints, labels


def map_angles(outputs_deg: dict[str, np.ndarray]) -> dict[str, dict[str, np.ndarray]]:
    """Model outputs (label -> (T, 3) degrees; ``LKneeAngles`` or ``LKneeAnglesV``) -> variable -> side ->
    (T,) degrees, for the variables of ``ANGLE_LABELS`` the file has (on either side)."""
    out: dict[str, dict[str, np.ndarray]] = {}
    for var, (stem, k) in ANGLE_LABELS.items():
        for side in SIDES:
            for label in (f"{_PREFIX[side]}{stem}", f"{_PREFIX[side]}{stem}V"):
                a = outputs_deg.get(label)
                if a is not None and np.isfinite(a[:, k]).any():
                    out.setdefault(var, {})[side] = np.asarray(a[:, k], dtype=np.float64)
                    break
    return out


def up_axis_of(joints_mm: dict[str, np.ndarray]) -> tuple[int, float]:
    """(axis, sign) of the vertical of a marker frame: the axis along which the hips (else knees, ankles)
    sit furthest from the heels, sign +1 when up is its positive direction (ValueError when neither is
    there)."""
    for upper in ("hip", "knee", "ankle"):
        names = [f"{s}_{upper}" for s in SIDES if f"{s}_{upper}" in joints_mm]
        heels = [f"{s}_heel" for s in SIDES if f"{s}_heel" in joints_mm]
        if names and heels:
            top = np.nanmean(np.concatenate([joints_mm[n] for n in names]), axis=0)
            bottom = np.nanmean(np.concatenate([joints_mm[n] for n in heels]), axis=0)
            axis = int(np.argmax(np.abs(top - bottom)))
            return axis, float(np.sign(top[axis] - bottom[axis]) or 1.0)
    raise ValueError("reference: no heel and hip/knee/ankle markers to tell which axis is up")
