"""The synthetic walker's Halpe-26 points rewritten in any registered keypoint layout (for testing and
benchmarking layout recognition: the same walk in every layout)."""

from __future__ import annotations

import numpy as np
from gaitcap.reconstruction.skeletons import get_skeleton

# Joints a layout has and Halpe-26 lacks: (name part, Halpe-26 joint it belongs to, offset mm), placed
# rigidly at that joint plus the offset (face points at the nose, hand points at the wrist, ...).
_NEAR = (("upper_neck", "neck", (0, 0, 40)), ("head_top", "head", (0, 0, 60)), ("foot_index", "big_toe", (0, 0, 0)),
         ("eye_inner", "eye", (0, 0, -8)), ("eye_outer", "eye", (0, 0, 8)), ("mouth", "nose", (0, 0, -50)),
         ("pinky", "wrist", (0, 0, -60)), ("index", "wrist", (0, 0, -70)), ("thumb", "wrist", (0, 0, -40)),
         ("hand_", "wrist", (0, 0, -50)), ("face_", "nose", (0, 0, -20)))
_CENTRAL = ("neck", "head", "nose")


def points_in_layout(points_mm: np.ndarray, layout: str) -> np.ndarray:
    """Halpe-26 points (T, 26, 3) mm -> (T, J, 3) mm in ``layout``'s joint order."""
    halpe, skel = get_skeleton("halpe26"), get_skeleton(layout)
    out = np.empty((points_mm.shape[0], skel.num_joints, 3))
    for j, name in enumerate(skel.joint_names):
        if halpe.has(name):
            out[:, j] = points_mm[:, halpe.index(name)]
            continue
        side = next((s for s in ("left_", "right_") if name.startswith(s)), "")
        part = name[len(side):]
        base, offset = next((b, o) for k, b, o in _NEAR if part.startswith(k) or part.endswith(k.rstrip("_")))
        out[:, j] = points_mm[:, halpe.index(base if base in _CENTRAL else side + base)] + np.asarray(offset, float)
    return out
