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
    """Detections of a synthetic trial (``gaitcap.simulator.make_trial(...)``): ``.detections``
    (a :class:`gaitcap.reconstruction.detections.Detections`, one person) and, for several people, ``.multi``
    with all people's keypoints per camera (C, T, P, J, 3)."""

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
        det = trial.detections
        self.skeleton = det.skeleton
        self._cameras = tuple(det.camera_names)
        multi = getattr(trial, "multi", None)
        # (C, T, P, J, 3) for all people, or the single person as P = 1.
        people = np.asarray(multi, dtype=np.float64) if multi is not None else det.keypoints[:, :, None]
        if people.ndim != 5 or people.shape[:2] != det.keypoints.shape[:2] or people.shape[3:] != det.keypoints.shape[2:]:
            raise ValueError(
                f"simulated trial: multi-person keypoints must have shape (C, T, P, J, 3) matching "
                f"detections {det.keypoints.shape}, got {people.shape}"
            )
        self._people = people

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
