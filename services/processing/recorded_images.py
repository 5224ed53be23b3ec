"""Which images a trial's recording holds per camera, for the data-quality judgement.

From the recorder's summary (frame ids less its gaps) when it has one; from the file itself (the images'
timestamps through the MCAP index, placed on the keypoints' frame grid) for a recording recovered after a
recorder crash (no summary) and for a camera whose frame counter restarted (its ids are another count).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np
from gaitcap.acquisition.recording.reader import read_image_times
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.services.processing.quality import images_on_grid, recorded_frame_ids


@dataclass(frozen=True)
class RecordedImages:
    """``frames``: {camera: sorted frame ids of its recorded images} (counted from the file when the
    recorder's summary has no cameras); ``recovered``: the file was recovered after a recorder crash; ``dropped``: {camera: images the recorder dropped,
    its queue full} (the summary's; empty without one)."""

    frames: dict[str, np.ndarray]
    recovered: bool = False
    dropped: dict[str, int] = field(default_factory=dict)


def recorded_images(path: str | os.PathLike, summary: dict, recording: MultiViewKeypoints) -> RecordedImages:
    """The images of ``path`` per camera (``summary``: its :func:`read_summary`; ``recording``: its keypoints)."""
    cameras = summary.get("cameras") or {}
    by_time = None if not cameras else sorted(set(recording.restarts) | {c for c, t in cameras.items() if t.get("restarts")})
    frames = {} if not cameras else {c: ids for c, ids in recorded_frame_ids(summary).items() if c not in by_time}
    if by_time is None or by_time:
        times = read_image_times(path, cameras=by_time)
        frames.update(images_on_grid(times, camera_names=recording.camera_names,
                                     timestamps_ns=recording.timestamps_ns, frame_ids=recording.frame_ids))
    dropped = {c: int(k) for c, k in (summary.get("dropped_images") or {}).items() if k}
    return RecordedImages(frames, recovered=summary.get("recovered") is True, dropped=dropped)
