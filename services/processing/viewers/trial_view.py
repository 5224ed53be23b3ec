"""What the viewer files show of one processed trial, gathered once (:class:`TrialView`).

Times: the trajectory's ``times_s`` are seconds since ``start_ns``, the camera timestamp (ns) of the
trial's first frame set, so results line up with the recorded images on Foxglove's and Rerun's
timelines (an event at ``t`` s is logged at ``start_ns + t * 1e9`` ns).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.result import Reconstruction


@dataclass(frozen=True, eq=False)
class TrialView:
    """One stage's trajectory and what the viewers show around it.

    Attributes:
    trial_id: the trial.
    trajectory: the stage's :class:`~gaitcap.reconstruction.result.Reconstruction`: ``points_mm``
        (T, J, 3) mm, NaN where unknown; ``times_s`` (T,) s since ``start_ns``; ``joint_names`` (J,).
    bones: (B, 2) joint index pairs to draw.
    rig: the calibrated cameras.
    start_ns: camera timestamp of ``times_s == 0``, ns.
    confidence: (T, J) per-joint confidence 0..1 (mean 2D detection confidence of the cameras that saw
        the joint; 0 where none did), or None.
    report: the ``GaitReport``, or None when no gait parameters could be computed.
    recording: the trial MCAP (images and 2D keypoints), or None.
    keypoints: the recording's ``MultiViewKeypoints`` (everyone's 2D keypoints), or None.
    """

    trial_id: str
    trajectory: Reconstruction
    bones: np.ndarray
    rig: Rig
    start_ns: int
    confidence: np.ndarray | None = None
    report: Any = None
    recording: Path | None = None
    keypoints: Any = None

    @property
    def points_mm(self) -> np.ndarray:
        """(T, J, 3) mm."""
        return self.trajectory.points_mm

    @property
    def times_s(self) -> np.ndarray:
        """(T,) s since ``start_ns``."""
        return self.trajectory.times_s

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(self.trajectory.joint_names)

    def __post_init__(self) -> None:
        t, j = self.points_mm.shape[:2]
        if self.points_mm.shape != (t, j, 3) or self.times_s.shape != (t,) or len(self.joint_names) != j:
            raise ValueError(f"trial {self.trial_id}: points_mm {self.points_mm.shape}, times_s "
                             f"{self.times_s.shape} and {len(self.joint_names)} joint names do not agree")
        if t > 1 and not np.all(np.diff(self.times_s) > 0):
            raise ValueError(f"trial {self.trial_id}: times_s must increase")
        if self.confidence is not None and self.confidence.shape != (t, j):
            raise ValueError(f"trial {self.trial_id}: confidence must be (T, J) = {(t, j)}, "
                             f"got {self.confidence.shape}")
        bones = np.asarray(self.bones, dtype=np.int64).reshape(-1, 2)
        if bones.size and (bones.min() < 0 or bones.max() >= j):
            raise ValueError(f"trial {self.trial_id}: bones index joints outside 0..{j - 1}")
        object.__setattr__(self, "bones", bones)

    def time_ns(self, seconds) -> np.ndarray:
        """Seconds since the start -> camera-clock ns (int64)."""
        return self.start_ns + np.round(np.asarray(seconds, dtype=np.float64) * 1e9).astype(np.int64)


def start_ns_of(keypoints) -> int:
    """Camera timestamp (ns) of ``times_s == 0`` of a ``MultiViewKeypoints``: the median camera
    timestamp of the first frame set that has one, less its time since the start."""
    stamps = np.asarray(keypoints.timestamps_ns)
    seen = np.flatnonzero((stamps >= 0).any(axis=0))
    if seen.size == 0:
        raise ValueError("keypoints: no camera timestamps")
    k = int(seen[0])
    column = stamps[:, k][stamps[:, k] >= 0]
    ref = int(column.min())  # medians of absolute ns in float64 would round to 256 ns
    return ref + int(round(float(np.median(column - ref)))) - int(round(float(keypoints.times_s[k]) * 1e9))


def joint_confidence(detections, frames: int) -> np.ndarray | None:
    """(T, J) mean 2D confidence over the cameras that saw each joint (0 where none did); None when the
    detections do not have ``frames`` frames."""
    kp = detections.one_person  # (C, T, J, 3)
    if kp.shape[1] != frames:
        return None
    conf = np.nan_to_num(kp[..., 2])
    seen = (conf > 0).sum(axis=0)
    return np.where(seen > 0, conf.sum(axis=0) / np.maximum(seen, 1), 0.0)
