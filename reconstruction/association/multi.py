"""Several people's 2D keypoints per camera and frame, in no particular order: association's input."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.detections import set_validated_fields
from gaitcap.reconstruction.skeletons import Skeleton


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
        set_validated_fields(self, layout="(C, T, P, J, 3)")

    @property
    def shape(self) -> tuple[int, int, int, int]:
        """(C, T, P, J)."""
        c, t, p, j, _ = self.keypoints.shape
        return c, t, p, j

    def confident(self, threshold: float) -> np.ndarray:
        """(C, T, P, J) bool: finite x, y and confidence > threshold."""
        kp = self.keypoints
        return np.isfinite(kp).all(-1) & (np.nan_to_num(kp[..., 2]) > threshold)
