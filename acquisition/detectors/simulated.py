"""The simulated detector: the synthetic world's noisy 2D keypoints, looked up by camera and frame.

It ignores the pixels, so the live pipeline (camera node -> detector node -> recorder) runs on simulated
frames at full speed with the ground truth's noise model, and the output is deterministic.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from gaitcap.acquisition.detectors.base import DetectorConfig, empty_keypoints, register_detector


@register_detector
@dataclass(frozen=True, eq=False)
class SimulatedConfig(DetectorConfig):
    """Detections of a synthetic trial (``gaitcap.simulator.make_trial(...)``): ``.everyone()``, every
    person's keypoints per camera (a :class:`gaitcap.reconstruction.keypoints.MultiViewKeypoints`)."""

    kind = "simulated"
    trial: Any

    def build(self) -> SimulatedDetector:
        return SimulatedDetector(self.trial)


class SimulatedDetector:
    """Returns the trial's keypoints of camera ``camera`` at frame ``frame_id`` as (P, J, 3); frame ids past
    the walk's end are those of a camera playing it again (frame ``frame_id mod num_frames``).

    People whose keypoints are all missing in that view (NaN or confidence 0) are left out, as a real
    detector would not report them.
    """

    def __init__(self, trial: Any):
        everyone = trial.everyone()
        self.skeleton = everyone.skeleton
        self._cameras = everyone.camera_names
        self._people = everyone.keypoints  # (C, T, P, J, 3)

    @property
    def camera_names(self) -> tuple[str, ...]:
        return self._cameras

    @property
    def num_frames(self) -> int:
        return self._people.shape[1]

    def detect(self, image_bgr: np.ndarray | None, *, camera: str, frame_id: int, timestamp_ns: int) -> np.ndarray:
        """(P, J, 3) x px, y px, confidence of the people seen by ``camera`` in frame ``frame_id``."""
        try:
            c = self._cameras.index(camera)
        except ValueError:
            raise ValueError(f"simulated detector: unknown camera {camera!r}; trial cameras: {list(self._cameras)}") from None
        if frame_id < 0:
            raise ValueError(f"simulated detector: camera {camera}: frame id {frame_id} is negative")
        people = self._people[c, frame_id % self.num_frames]  # a looping camera plays the walk again
        seen = (np.isfinite(people).all(-1) & (np.nan_to_num(people[..., 2]) > 0)).any(-1)
        if not seen.any():
            return empty_keypoints(self.skeleton.num_joints)
        return people[seen].copy()
