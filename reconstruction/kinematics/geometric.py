"""Joint angles measured directly on keypoints (degrees, room frame z up), the reference for the model fit.

For the synthetic walker (rigid thigh, shank and foot; pelvis upright, turning only about the vertical)
these are its true joint angles. Conventions as in :mod:`gaitcap.reconstruction.kinematics.angles`:
- pelvis frame: forward = up x (right hip - left hip), horizontal;
- hip flexion / adduction: the thigh (hip -> knee) in the pelvis's sagittal / frontal plane;
- knee flexion: the angle between the thigh and the shank (0 = straight, negative = hyperextended);
- ankle dorsiflexion: 90 degrees minus the angle between the shank (ankle -> knee) and the foot (heel ->
  big toe).
These are the norm sources' definitions (angles between segments through joint centres: a straight leg
is 0, a foot at right angles to the shank is 0). A model's zero is not: the OpenSim model's knee in its
zero pose is 2.3 deg hyperextended measured through its own joint centres and knee markers, and its
heel marker sits higher than its toe markers (4.5 deg). :func:`zero_pose_offsets` measures a model's
zero pose this way; the model's angle plus that offset is the angle in these definitions
(``kinematics_report``'s ``zero_offsets_deg``).
"""

from __future__ import annotations

import numpy as np

UP = np.array([0.0, 0.0, 1.0])


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    cos = np.sum(_unit(a) * _unit(b), axis=-1)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def keypoint_angles(points_mm: np.ndarray, joint_names) -> dict[str, dict[str, np.ndarray]]:
    """variable -> side -> (T,) degrees for hip_flexion, hip_adduction, knee_flexion, ankle_dorsiflexion
    (KeyError naming a missing joint)."""
    names = [str(n) for n in joint_names]
    pts = np.asarray(points_mm, dtype=np.float64)

    def j(name: str) -> np.ndarray:
        if name not in names:
            raise KeyError(f"joint_names: no {name!r}")
        return pts[:, names.index(name)]

    right = j("right_hip") - j("left_hip")
    right[..., 2] = 0.0
    right = _unit(right)
    fwd = np.cross(UP, right)
    out: dict[str, dict[str, np.ndarray]] = {k: {} for k in
                                             ("hip_flexion", "hip_adduction", "knee_flexion", "ankle_dorsiflexion")}
    for side, medial_sign in (("left", 1.0), ("right", -1.0)):
        hip, knee, ankle = j(f"{side}_hip"), j(f"{side}_knee"), j(f"{side}_ankle")
        thigh, shank = knee - hip, ankle - knee
        down = -(thigh @ UP)
        out["hip_flexion"][side] = np.degrees(np.arctan2(np.sum(thigh * fwd, -1), down))
        out["hip_adduction"][side] = np.degrees(np.arctan2(medial_sign * np.sum(thigh * right, -1), down))
        bend = np.sign(np.sum(np.cross(thigh, shank) * right, -1))  # - when the knee is ahead of the leg line
        out["knee_flexion"][side] = np.where(bend > 0, -1.0, 1.0) * _angle_deg(thigh, shank)
        foot = j(f"{side}_big_toe") - j(f"{side}_heel")
        out["ankle_dorsiflexion"][side] = 90.0 - _angle_deg(-shank, foot)
    return out


# the model's marker names (every layout spells these alike) -> the keypoint the angles above use
MODEL_MARKER_JOINTS = {f"{m[0]}{part}": f"{side}_{joint}" for side, m in (("left", "L"), ("right", "R"))
                       for part, joint in (("Hip", "hip"), ("Knee", "knee"), ("Ankle", "ankle"),
                                           ("Heel", "heel"), ("BigToe", "big_toe"))}


def model_zero_offsets(markers_mm: dict[str, np.ndarray]) -> dict[str, dict[str, float]]:
    """:func:`zero_pose_offsets` of a model's markers (marker name -> (3,) mm, room frame z up, the model in
    its zero pose); a variable whose markers the model lacks is NaN."""
    names = list(MODEL_MARKER_JOINTS.values())
    pts = np.array([markers_mm.get(m, np.full(3, np.nan)) for m in MODEL_MARKER_JOINTS], dtype=np.float64)
    with np.errstate(invalid="ignore"):
        return zero_pose_offsets(pts, names)


def zero_pose_offsets(model_points_mm: np.ndarray, joint_names) -> dict[str, dict[str, float]]:
    """The keypoint angles of a model's markers in its zero pose ((J, 3) mm, room frame): what the model
    calls 0 degrees, measured like the keypoints."""
    angles = keypoint_angles(np.asarray(model_points_mm, dtype=np.float64)[None], joint_names)
    return {var: {side: float(v[0]) for side, v in by_side.items()} for var, by_side in angles.items()}
