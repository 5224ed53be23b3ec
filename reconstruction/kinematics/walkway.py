"""The walkway's direction: the model is fitted with the walk along its x axis, and its coordinates turned
back into the room.

The model's ground-pelvis joint turns the pelvis by Rz(tilt) Rx(list) Ry(rotation) about the ground's axes
(OpenSim's frame, y up), and the fit holds the tilt near 0 (no keypoint determines it). Held about the
room's z axis, that is the pelvis's anatomical tilt only for a walk along the room's x axis: on a walk
along the room's diagonal (the rig films the real walks there) the list, about the room's x axis, carries
half of the tilt, so the hips' obliquity tilted the pelvis forward and back by as much and hip flexion
followed (real Plug-in-Gait walks through the rig: hip flexion RMSE 2.2-3.5 deg against the model markers'
own thigh angles' 1.3-1.4, docs/kinematics.md). Fitted with the walkway along x, the tilt held is the
anatomical one whatever way the walkway runs in the room.
"""

from __future__ import annotations

import numpy as np
from gaitcap.reconstruction.kinematics.angles import turned_pelvis


def walkway_heading_rad(left_hip: np.ndarray, right_hip: np.ndarray) -> float:
    """The axis the patient faces along, about the room's vertical (radians from the room's x axis towards
    its y, in (-pi/2, pi/2]): the axial mean (walking back along it counts the same) of the facing
    direction up x (right hip - left hip) over the frames that have both hips; 0 without any.
    ``left_hip``, ``right_hip``: (T, 3) room frame (z up)."""
    lateral = np.asarray(right_hip, dtype=np.float64) - np.asarray(left_hip, dtype=np.float64)
    ok = np.isfinite(lateral).all(axis=-1)
    if not ok.any():
        return 0.0
    facing = np.arctan2(lateral[ok, 0], -lateral[ok, 1])  # up x lateral = (-ly, lx): its angle
    doubled = np.mean(np.exp(2j * facing))
    return float(np.angle(doubled) / 2.0) if abs(doubled) > 0 else 0.0


def turned_points(points: np.ndarray, heading_rad: float) -> np.ndarray:
    """Points (..., 3) in the room frame (z up) turned by ``-heading_rad`` about the vertical: a walk along
    ``heading_rad`` then runs along x."""
    c, s = np.cos(heading_rad), np.sin(heading_rad)
    turn = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    return np.asarray(points, dtype=np.float64) @ turn.T


PELVIS_TRANSLATIONS = ("pelvis_tx", "pelvis_tz")


def coordinates_in_room(coordinates: dict[str, np.ndarray], heading_rad: float) -> dict[str, np.ndarray]:
    """A model's coordinates fitted to :func:`turned_points` (degrees; pelvis translations m, OpenSim's
    frame) as they are in the room: the same pose, its pelvis's orientation and horizontal place turned
    back by ``heading_rad`` (a turn about the room's z is one about OpenSim's y by the same angle)."""
    out = turned_pelvis(coordinates, -heading_rad)
    if all(k in coordinates for k in PELVIS_TRANSLATIONS):
        x, z = (np.asarray(coordinates[k], dtype=np.float64) for k in PELVIS_TRANSLATIONS)
        c, s = np.cos(heading_rad), np.sin(heading_rad)
        out["pelvis_tx"], out["pelvis_tz"] = c * x + s * z, -s * x + c * z
    return out
