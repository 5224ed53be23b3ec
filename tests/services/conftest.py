"""Helpers for the worker tests: a synthetic trial written as the recorder writes it (keypoints and
calibration in a trial MCAP; no image frames, which the worker does not read)."""

import json
from pathlib import Path

import numpy as np
from gaitcap.reconstruction.calibration_io import save_rig


def rig_toml(rig, tmp_dir: Path) -> str:
    path = tmp_dir / "rig.toml"
    save_rig(rig, path)
    return path.read_text()


def write_trial_mcap(trial, path: Path, *, metadata: dict | None = None) -> Path:
    """The synthetic trial's patient detections as a trial MCAP (frame ids 0.., camera clocks in ns)."""
    from gaitcap.acquisition.recording.writer import TrialWriter

    path.parent.mkdir(parents=True, exist_ok=True)
    writer = TrialWriter(path)
    t0_ns = 1_700_000_000_000_000_000
    writer.start(metadata=metadata or {"trial_id": path.stem}, calibration_toml=rig_toml(trial.rig, path.parent),
                 time_ns=t0_ns)
    kp = trial.detections.keypoints
    for c, cam in enumerate(trial.detections.camera_names):
        for i, t in enumerate(trial.detections.times_s):
            ts = t0_ns + int(round(t * 1e9))
            people = [] if not np.isfinite(kp[c, i, :, 2]).any() else [np.nan_to_num(kp[c, i]).round(2).tolist()]
            msg = {"camera": cam, "frame_id": i, "timestamp_ns": ts, "skeleton": trial.skeleton.name,
                   "people": people, "detector_ms": 0.0}
            writer.add_keypoints(cam, json.dumps(msg).encode(), timestamp_ns=ts, frame_id=i)
    return writer.finish({"frames": int(kp.shape[1])})


def write_multi_trial_mcap(trial, path: Path, *, stills: bool = False) -> Path:
    """Everyone's detections of a multi-person synthetic trial (``trial.multi``) as a trial MCAP: each
    camera frame lists the people detected in it, in the slots' (arbitrary) order. ``stills``: also a
    small grey image per camera and frame (so the recording has images to click on)."""
    import cv2
    from gaitcap.acquisition.encoding import image_message
    from gaitcap.acquisition.recording.writer import TrialWriter

    jpeg = cv2.imencode(".jpg", np.full((36, 64, 3), 128, np.uint8))[1].tobytes() if stills else b""

    path.parent.mkdir(parents=True, exist_ok=True)
    writer = TrialWriter(path)
    t0_ns = 1_700_000_000_000_000_000
    writer.start(metadata={"trial_id": path.stem}, calibration_toml=rig_toml(trial.rig, path.parent), time_ns=t0_ns)
    kp = trial.multi.keypoints  # (C, T, P, J, 3)
    for c, cam in enumerate(trial.rig.names):
        for i, t in enumerate(trial.times_s):
            ts = t0_ns + int(round(t * 1e9))
            people = [np.nan_to_num(kp[c, i, p]).round(2).tolist() for p in range(kp.shape[2])
                      if trial.multi.identity[c, i, p] >= 0]
            msg = {"camera": cam, "frame_id": i, "timestamp_ns": ts, "skeleton": trial.skeleton.name,
                   "people": people, "detector_ms": 0.0}
            writer.add_keypoints(cam, json.dumps(msg).encode(), timestamp_ns=ts, frame_id=i)
            if stills:
                writer.add_frame(cam, image_message(jpeg, camera=cam, timestamp_ns=ts), timestamp_ns=ts, frame_id=i,
                                 receive_ns=ts)
    return writer.finish({"frames": int(kp.shape[1])})
