"""A synthetic trial written as the recorder writes a trial: keypoints and calibration in a trial MCAP.

For benchmarks and tests of everything downstream of the recorder (the worker, reprocessing, the viewers):
no image frames unless asked for (the worker reads only keypoints). Frame ids count from 0; the camera
clock starts at a fixed epoch (ns) so recordings are reproducible.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from gaitcap.acquisition.recording.writer import TrialWriter
from gaitcap.reconstruction.calibration_io import rig_to_toml_text

T0_NS = 1_700_000_000_000_000_000
"""The camera clock at the trial's first frame, ns."""


def write_keypoint_recording(trial, path: str | Path, *, metadata: dict | None = None, everyone: bool = False,
                             stills: bool = False, live: np.ndarray | None = None) -> Path:
    """Write ``trial`` (a :class:`~gaitcap.simulator.trial.SyntheticTrial`) to ``path`` and
    return the finished file's path.

    everyone: every person detected in each camera frame, in the detector's (arbitrary) slot order
        (``trial.multi``), instead of the patient alone;
    stills: also a small grey JPEG per camera and frame (a recording with images to click on);
    live: (C, T) bool, the camera frames whose keypoints the live detector caught (default all): the others
        have their image only (with ``stills``), as when the live detector fell behind.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    writer = TrialWriter(path)
    writer.start(metadata=metadata or {"trial_id": path.stem}, calibration_toml=rig_to_toml_text(trial.rig),
                 time_ns=T0_NS)
    jpeg = _grey_jpeg() if stills else b""
    for c, camera in enumerate(trial.rig.names):
        for i, time_s in enumerate(trial.times_s):
            ts = T0_NS + int(round(time_s * 1e9))
            people = _everyone(trial, c, i) if everyone else _patient(trial, c, i)
            msg = {"camera": camera, "frame_id": i, "timestamp_ns": ts, "skeleton": trial.skeleton.name,
                   "people": people, "detector_ms": 0.0}
            if live is None or live[c, i]:
                writer.add_keypoints(camera, json.dumps(msg).encode(), timestamp_ns=ts, frame_id=i)
            if stills:
                from gaitcap.acquisition.encoding import image_message

                writer.add_frame(camera, image_message(jpeg, camera=camera, timestamp_ns=ts), timestamp_ns=ts,
                                 frame_id=i, receive_ns=ts)
    return writer.finish({"frames": int(trial.times_s.size)})


def _patient(trial, c: int, i: int) -> list:
    kp = trial.detections.one_person[c, i]  # the detections' cameras are the rig's, in its order
    return [np.nan_to_num(kp).round(2).tolist()] if np.isfinite(kp[:, 2]).any() else []


def _everyone(trial, c: int, i: int) -> list:
    kp, identity = trial.multi.observed.keypoints[c, i], trial.multi.identity[c, i]
    return [np.nan_to_num(kp[p]).round(2).tolist() for p in range(kp.shape[0]) if identity[p] >= 0]


def _grey_jpeg() -> bytes:
    import cv2

    return cv2.imencode(".jpg", np.full((36, 64, 3), 128, np.uint8))[1].tobytes()
