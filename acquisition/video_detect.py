"""2D keypoints from existing multi-view videos (one file per camera), for offline reconstruction.

Each video is one camera, named after the file stem; frame ``i`` of every file is frame set ``i``
(times ``i / fps`` from the files' frame rate). Files of different lengths are padded with missing
frames (NaN, confidence 0). Every person the detector finds is kept (most confident first in each camera
frame): who the patient is is decided across cameras by the processing path's association, never per
camera.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path

import numpy as np
from gaitcap.acquisition.drivers.base import CaptureSettings
from gaitcap.acquisition.drivers.video import VideoCamera
from gaitcap.acquisition.importers.keypoint_input import sort_people
from gaitcap.reconstruction.keypoints import MultiViewKeypoints

log = logging.getLogger(__name__)
VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv", ".m4v", ".webm")


def find_videos(folder: str | Path) -> list[Path]:
    """The video files of a folder (sorted); ValueError when there are fewer than one."""
    d = Path(folder)
    if not d.is_dir():
        raise FileNotFoundError(f"video folder {d} does not exist")
    files = sorted(p for p in d.iterdir() if p.suffix.lower() in VIDEO_SUFFIXES and p.is_file())
    if not files:
        raise ValueError(f"video folder {d}: no video files ({', '.join(VIDEO_SUFFIXES)})")
    stems = [p.stem for p in files]
    dup = sorted({s for s in stems if stems.count(s) > 1})
    if dup:
        raise ValueError(f"video folder {d}: several files per camera name {dup}")
    return files


def detect_videos(files: list[Path], detector, *, fps: float | None = None,
                  on_frame: Callable[[], None] | None = None) -> MultiViewKeypoints:
    """Run ``detector`` on every frame of every file (camera = file stem); the frames are ``fps`` apart
    (default: the files' frame rate)."""
    per_cam: list[list[np.ndarray]] = []
    rates = []
    for path in files:
        cam = VideoCamera(path, realtime=False)
        cam.open()
        cam.configure(CaptureSettings(fps=fps or 30.0, exposure_us=None))
        rates.append(fps or cam.file_fps or 30.0)
        cam.start(0)
        found = []
        for frame in cam.frames():
            people = np.asarray(detector.detect(frame.image, camera=cam.name, frame_id=frame.frame_id,
                                                timestamp_ns=frame.timestamp_ns), dtype=np.float64)
            found.append(people.reshape(-1, detector.skeleton.num_joints, 3))
            if on_frame is not None:
                on_frame()
        cam.close()
        if not found:
            raise ValueError(f"video {path}: no frames could be read")
        per_cam.append(found)
    if max(rates) - min(rates) > 0.01 * max(rates):
        raise ValueError(f"videos have different frame rates {dict(zip([p.name for p in files], rates, strict=True))}; "
                         "give --fps to force one")
    t = max(len(f) for f in per_cam)
    p = max((len(people) for f in per_cam for people in f), default=0)
    j = detector.skeleton.num_joints
    out = np.full((len(files), t, p, j, 3), np.nan)
    out[..., 2] = 0.0
    for c, frames in enumerate(per_cam):
        for i, people in enumerate(frames):
            out[c, i, : len(people)] = people
    rate = float(rates[0])
    return MultiViewKeypoints(sort_people(out), tuple(f.stem for f in files), np.arange(t) / rate, detector.skeleton)
