"""Marker layouts: which keypoint of a gaitcap skeleton is which marker of the OpenSim marker sets.

The marker sets, scaling and IK setups are Pose2Sim's (one per keypoint layout; see docs/kinematics.md).
Registry: ``LAYOUTS[setup]``; :func:`layout_for` picks the one for a skeleton name.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _limb(side: str, joint: str) -> str:
    return ("L" if side == "left" else "R") + "".join(w.capitalize() for w in joint.split("_"))


def _bilateral(joints: tuple[str, ...]) -> dict[str, str]:
    return {f"{side}_{j}": _limb(side, j) for side in ("left", "right") for j in joints}


_BODY = ("shoulder", "elbow", "wrist", "hip", "knee", "ankle")
_FEET = ("big_toe", "small_toe", "heel")


@dataclass(frozen=True)
class MarkerLayout:
    """One OpenSim marker set.

    Attributes:
        setup: suffix of the Pose2Sim files (``Markers_<setup>.xml``, ``Scaling_Setup_Pose2Sim_<setup>.xml``,
            ``IK_Setup_Pose2Sim_<setup>.xml``; the marker file of "Blazepose" is spelled "BlazePose").
        markers: keypoint name -> marker name.
    """

    setup: str
    markers: dict[str, str]

    def select(self, points_mm: np.ndarray, joint_names) -> tuple[tuple[str, ...], np.ndarray]:
        """(marker names, points (T, M, 3) mm) of the keypoints this layout has, in the layout's order.

        ValueError naming the missing keypoints when fewer than the hips, knees and ankles are there."""
        names = [str(n) for n in joint_names]
        pts = np.asarray(points_mm, dtype=np.float64)
        if pts.ndim != 3 or pts.shape[1] != len(names) or pts.shape[2] != 3:
            raise ValueError(f"points_mm: expected (T, {len(names)}, 3) for {len(names)} joint names, got {pts.shape}")
        needed = [f"{s}_{j}" for s in ("left", "right") for j in ("hip", "knee", "ankle")]
        missing = [n for n in needed if n not in names]
        if missing:
            raise ValueError(f"joint_names: no {', '.join(missing)}: a model fit needs hips, knees and ankles")
        have = [(k, m) for k, m in self.markers.items() if k in names]
        idx = [names.index(k) for k, _ in have]
        return tuple(m for _, m in have), pts[:, idx]


LAYOUTS: dict[str, MarkerLayout] = {
    "Halpe26": MarkerLayout("Halpe26", {
        "nose": "Nose", "head": "Head", "neck": "Neck", "pelvis": "Hip", **_bilateral(_BODY + _FEET)}),
    "Body25": MarkerLayout("Body25", {
        "nose": "Nose", "neck": "Neck", "pelvis": "CHip", **_bilateral(_BODY + _FEET)}),
    "Body25b": MarkerLayout("Body25b", {
        "nose": "Nose", "head_top": "Head", "upper_neck": "Neck", **_bilateral(_BODY + _FEET)}),
    "Coco17": MarkerLayout("Coco17", {"nose": "Nose", **_bilateral(_BODY)}),
    "Coco133": MarkerLayout("Coco133", {
        "nose": "Nose", "left_eye": "LEye", "right_eye": "REye", **_bilateral(_BODY + _FEET)}),
    "Blazepose": MarkerLayout("Blazepose", {
        "nose": "Nose", "left_eye": "LEye", "right_eye": "REye", **_bilateral(_BODY + ("heel",)),
        "left_foot_index": "LBigToe", "right_foot_index": "RBigToe",
        **_bilateral(("pinky", "index", "thumb"))}),
}

# gaitcap skeleton name -> layout
SKELETON_LAYOUTS: dict[str, str] = {
    "halpe26": "Halpe26", "halpe136": "Halpe26", "body25": "Body25", "body25b": "Body25b", "coco17": "Coco17",
    "coco18": "Body25", "wholebody133": "Coco133", "mediapipe33": "Blazepose",
}


def layout_for(skeleton: str) -> MarkerLayout:
    """The marker layout of a skeleton (ValueError listing the skeletons that have one)."""
    key = skeleton.lower().replace("-", "").replace("_", "")
    if key not in SKELETON_LAYOUTS:
        raise ValueError(f"skeleton {skeleton!r} has no OpenSim marker layout; known: {sorted(SKELETON_LAYOUTS)}")
    return LAYOUTS[SKELETON_LAYOUTS[key]]


def guess_skeleton(joint_names) -> str:
    """The registered skeleton whose joint names are exactly ``joint_names`` (ValueError otherwise)."""
    from gaitcap.reconstruction.skeletons import SKELETONS

    names = tuple(str(n) for n in joint_names)
    for name, skel in SKELETONS.items():
        if skel.joint_names == names:
            return name
    raise ValueError(f"joint_names: {len(names)} names that match no known skeleton ({sorted(SKELETONS)})")
