"""NPZ files of keypoints: several people per camera and frame in, one chosen person out. Read here;
written by :mod:`gaitcap.acquisition.writers` (``reconstruction/`` writes no files).

Multi-person file keys: ``keypoints`` (C, T, P, J, 3) x px, y px, confidence; ``camera_names`` (C,)
str; ``times_s`` (T,); ``skeleton`` (str). A single-person file has ``keypoints`` (C, T, J, 3) and
the same other keys, plus whatever extra arrays the writer adds (e.g. ``track_id``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from gaitcap.reconstruction.association.multi import MultiPersonDetections
from gaitcap.reconstruction.detections import Detections

KEYS = ("keypoints", "camera_names", "times_s", "skeleton")


def _read(path: str | Path) -> tuple[np.ndarray, tuple[str, ...], np.ndarray, str]:
    """keypoints, camera names, times (s) and skeleton name of a keypoint file; errors name the file."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"keypoint file {path} does not exist")
    with np.load(path, allow_pickle=False) as data:
        missing = [k for k in KEYS if k not in data.files]
        if missing:
            raise ValueError(f"{path}: missing arrays {missing} (has {sorted(data.files)})")
        return (data["keypoints"], tuple(str(n) for n in data["camera_names"]), data["times_s"],
                str(data["skeleton"]))


def load_multi_npz(path: str | Path) -> MultiPersonDetections:
    """Read a multi-person keypoint file (ValueError naming a missing key or bad array)."""
    kp, names, times, skeleton = _read(path)
    if kp.ndim == 4:
        kp = kp[:, :, None]  # one person per camera and frame
    return MultiPersonDetections(keypoints=kp, camera_names=names, times_s=times, skeleton=skeleton)


def load_detections_npz(path: str | Path) -> Detections:
    """Read a single-person keypoint file written by :func:`gaitcap.acquisition.writers.save_detections_npz`."""
    kp, names, times, skeleton = _read(path)
    return Detections(keypoints=kp, camera_names=names, times_s=times, skeleton=skeleton)

