"""2D keypoint detections from several synchronised cameras: the input of every reconstruction."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.skeletons import Skeleton, get_skeleton


def validate_keypoints(keypoints, camera_names, times_s, skeleton: Skeleton | str, *, layout: str
                       ) -> tuple[np.ndarray, tuple[str, ...], np.ndarray, Skeleton]:
    """Check keypoints laid out as ``layout`` ("(C, T, J, 3)" or "(C, T, P, J, 3)") against their
    camera names (C,), frame times (T,) s and skeleton; ValueError naming the field that is wrong."""
    kp = np.asarray(keypoints, dtype=np.float64)
    names = tuple(str(n) for n in camera_names)
    skel = get_skeleton(skeleton) if isinstance(skeleton, str) else skeleton
    ndim = layout.count(",") + 1
    if kp.ndim != ndim or kp.shape[-1] != 3:
        raise ValueError(f"keypoints: expected shape {layout}, got {kp.shape}")
    c, t, j = kp.shape[0], kp.shape[1], kp.shape[-2]
    if len(names) != c:
        raise ValueError(f"camera_names: {len(names)} names for {c} cameras in keypoints")
    if len(set(names)) != c:
        raise ValueError(f"camera_names: duplicates in {list(names)}")
    if j != skel.num_joints:
        raise ValueError(f"keypoints: {j} joints but skeleton {skel.name} has {skel.num_joints}")
    times = np.asarray(times_s, dtype=np.float64).reshape(-1)
    if times.shape != (t,):
        raise ValueError(f"times_s: expected {t} times (one per frame), got {times.shape[0]}")
    if t > 1 and not np.all(np.diff(times) > 0):
        raise ValueError("times_s: must be strictly increasing")
    conf = kp[..., 2]
    if np.any(np.isfinite(conf) & ((conf < 0) | (conf > 1))):
        raise ValueError("keypoints: confidence (last channel) must lie in [0, 1]")
    return kp, names, times, skel


def confident_mask(keypoints: np.ndarray, threshold: float) -> np.ndarray:
    """(..., J) bool of keypoints (..., J, 3): finite x, y and confidence > threshold."""
    return np.isfinite(keypoints).all(-1) & (np.nan_to_num(keypoints[..., 2]) > threshold)


def set_validated_fields(obj, *, layout: str) -> None:
    """Validate a frozen dataclass's keypoints, camera_names, times_s and skeleton and store the
    normalised values (arrays as float64, names as a tuple, the skeleton as a :class:`Skeleton`)."""
    values = validate_keypoints(obj.keypoints, obj.camera_names, obj.times_s, obj.skeleton, layout=layout)
    for name, value in zip(("keypoints", "camera_names", "times_s", "skeleton"), values, strict=True):
        object.__setattr__(obj, name, value)


@dataclass(frozen=True, eq=False)
class Detections:
    """One person's 2D keypoints seen by C cameras over T frames.

    Attributes:
        keypoints: (C, T, J, 3) float: x px, y px, confidence in [0, 1]. Missing views are NaN or have
            confidence 0.
        camera_names: (C,) names, matched to the calibration by name.
        times_s: (T,) frame times in s (monotonic).
        skeleton: the keypoint layout (J joints).
    """

    keypoints: np.ndarray
    camera_names: tuple[str, ...]
    times_s: np.ndarray
    skeleton: Skeleton

    def __post_init__(self) -> None:
        set_validated_fields(self, layout="(C, T, J, 3)")

    @property
    def shape(self) -> tuple[int, int, int]:
        """(C, T, J)."""
        c, t, j, _ = self.keypoints.shape
        return c, t, j

    def aligned_to(self, rig: Rig) -> tuple[Detections, Rig]:
        """Reorder to the rig's camera order restricted to the cameras seen here.

        Raises ValueError naming the cameras that are not in the calibration.
        """
        sub = rig.subset(self.camera_names)  # raises naming missing cameras
        return self, sub

    def confident(self, threshold: float = 0.5) -> np.ndarray:
        """(C, T, J) bool: finite x, y and confidence > threshold."""
        return confident_mask(self.keypoints, threshold)
