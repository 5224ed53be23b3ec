"""Helpers for the recording tests: a tiny rig and a written trial MCAP."""

from __future__ import annotations

import json

import numpy as np
from gaitcap.acquisition.encoding import encode_jpeg, image_message
from gaitcap.acquisition.recording.writer import TrialWriter, WriterSettings
from gaitcap.reconstruction.calibration_io import rig_to_toml_text
from gaitcap.reconstruction.camera import Camera, Rig

CAMS = ("cam0", "cam1", "cam2")
FRAMES = 20
J = 26
T0_NS = 1_700_000_000_000_000_000
PERIOD_NS = 33_333_333


def tiny_rig() -> Rig:
    cams = []
    for i, name in enumerate(CAMS):
        k = np.array([[500.0, 0, 32], [0, 500.0, 24], [0, 0, 1]])
        cams.append(Camera(name, (64, 48), k, np.zeros(5), np.array([0.0, 0.1 * i, 0.0]),
                           np.array([0.0, 0.0, 3000.0 + i]), serial=str(1000 + i)))
    return Rig(tuple(cams))


def people_for(c: int, f: int, n: int = 2) -> np.ndarray:
    """Deterministic (n, J, 3) keypoints for camera c, frame f."""
    base = np.arange(J * 3, dtype=np.float64).reshape(J, 3) + 100 * c + f
    base[:, 2] = 0.9
    return np.stack([base + [1000 * p, 1000 * p, 0] for p in range(n)])  # confidences stay 0.9


def write_trial(path, *, finish: bool = True, missing: dict | None = None, compression: str = "lz4",
                flush_every: int | None = None):
    """Write CAMS x FRAMES frames (noise JPEGs), keypoints (2 people) and status; missing = {cam: {ids}}."""
    missing = missing or {}
    rng = np.random.default_rng(0)
    w = TrialWriter(path, WriterSettings(compression=compression, chunk_size_bytes=64 * 1024,
                                         flush_interval_s=3600))
    w.start(metadata={"patient": "p01", "speed": 1.2}, calibration_toml=rig_to_toml_text(tiny_rig()),
            time_ns=T0_NS)
    for f in range(FRAMES):
        for c, cam in enumerate(CAMS):
            if f in missing.get(cam, ()):
                continue
            ts = T0_NS + f * PERIOD_NS + 1000 * c
            jpeg = encode_jpeg(rng.integers(0, 255, (48, 64, 3), dtype=np.uint8))
            w.add_frame(cam, image_message(jpeg, camera=cam, timestamp_ns=ts), timestamp_ns=ts, frame_id=f,
                        receive_ns=ts + 1)
            kp = {"camera": cam, "frame_id": f, "timestamp_ns": ts, "skeleton": "halpe26",
                  "people": people_for(c, f).tolist()}
            w.add_keypoints(cam, json.dumps(kp).encode(), timestamp_ns=ts, frame_id=f)
        w.add_status(CAMS[0], {"camera": CAMS[0], "health": "ok", "frames": f}, time_ns=T0_NS + f * PERIOD_NS)
        if flush_every and f % flush_every == flush_every - 1:
            w.flush()
    if finish:
        return w.finish({"frames": FRAMES * len(CAMS)})
    w.flush()
    w.abort()
    return w.part_path
