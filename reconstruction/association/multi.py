"""Several people's 2D keypoints per camera and frame, in no particular order: association's input."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from reconstruction.skeletons import Skeleton, get_skeleton


@dataclass(frozen=True, eq=False)
class MultiPersonDetections:
    """Unordered people seen by C cameras over T frames, at most P per camera and frame.

    Attributes:
        keypoints: (C, T, P, J, 3) float: x px, y px, confidence in [0, 1]. Empty slots are NaN or have
            confidence 0; slot p of camera c need not be the same person as slot p of another camera or
            frame.
        camera_names: (C,) names, matched to the calibration by name.
        times_s: (T,) frame times in s (strictly increasing).
        skeleton: the keypoint layout (J joints).
    """

    keypoints: np.ndarray
    camera_names: tuple[str, ...]
    times_s: np.ndarray
    skeleton: Skeleton

    def __post_init__(self) -> None:
        kp = np.asarray(self.keypoints, dtype=np.float64)
        names = tuple(str(n) for n in self.camera_names)
        skel = get_skeleton(self.skeleton) if isinstance(self.skeleton, str) else self.skeleton
        if kp.ndim != 5 or kp.shape[-1] != 3:
            raise ValueError(f"keypoints: expected shape (C, T, P, J, 3), got {kp.shape}")
        c, t, _, j, _ = kp.shape
        if len(names) != c:
            raise ValueError(f"camera_names: {len(names)} names for {c} cameras in keypoints")
        if len(set(names)) != c:
            raise ValueError(f"camera_names: duplicates in {list(names)}")
        if j != skel.num_joints:
            raise ValueError(f"keypoints: {j} joints but skeleton {skel.name} has {skel.num_joints}")
        times = np.asarray(self.times_s, dtype=np.float64).reshape(-1)
        if times.shape != (t,):
            raise ValueError(f"times_s: expected {t} times (one per frame), got {times.shape[0]}")
        if t > 1 and not np.all(np.diff(times) > 0):
            raise ValueError("times_s: must be strictly increasing")
        conf = kp[..., 2]
        if np.any(np.isfinite(conf) & ((conf < 0) | (conf > 1))):
            raise ValueError("keypoints: confidence (last channel) must lie in [0, 1]")
        object.__setattr__(self, "keypoints", kp)
        object.__setattr__(self, "camera_names", names)
        object.__setattr__(self, "times_s", times)
        object.__setattr__(self, "skeleton", skel)

    @property
    def shape(self) -> tuple[int, int, int, int]:
        """(C, T, P, J)."""
        c, t, p, j, _ = self.keypoints.shape
        return c, t, p, j

    def confident(self, threshold: float) -> np.ndarray:
        """(C, T, P, J) bool: finite x, y and confidence > threshold."""
        kp = self.keypoints
        return np.isfinite(kp).all(-1) & (np.nan_to_num(kp[..., 2]) > threshold)
