"""Reading the files that ``reconstruction/`` parses: calibrations, keypoint NPZ files, walkway exports.
The counterpart of :mod:`gaitcap.acquisition.writers`; ``reconstruction/`` reads and writes no file (it
parses the text or arrays handed to it). Every error names the file.

Keypoint NPZ files: several people per camera and frame in, one chosen person out. Multi-person file
keys: ``keypoints`` (C, T, P, J, 3) x px, y px, confidence; ``camera_names`` (C,) str; ``times_s`` (T,);
``skeleton`` (str). A single-person file has ``keypoints`` (C, T, J, 3) and the same other keys, plus
whatever extra arrays the writer adds (e.g. ``track_id``).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from gaitcap.reconstruction.association.multi import MultiPersonDetections
from gaitcap.reconstruction.calibration_io import rig_from_text
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.detections import Detections
from gaitcap.reconstruction.gait.walkway import WalkwayTrial, walkway_from_csv_text

KEYS = ("keypoints", "camera_names", "times_s", "skeleton")


def load_rig(path: str | os.PathLike) -> Rig:
    """Read a calibration: ``.toml`` (aniposelib/Pose2Sim, metres) or ``.json`` (gaitcap, mm)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"calibration file {str(path)!r} does not exist")
    return rig_from_text(path.read_text(encoding="utf-8"), suffix=path.suffix, source=str(path))


def read_walkway_csv(path: str | os.PathLike) -> tuple[WalkwayTrial, ...]:
    """Read a walkway export (UTF-8 CSV, :mod:`gaitcap.reconstruction.gait.walkway`); errors name file:line."""
    with open(path, newline="", encoding="utf-8") as f:
        return walkway_from_csv_text(f.read(), source=str(path))


def _read_keypoints(path: str | os.PathLike) -> tuple[np.ndarray, tuple[str, ...], np.ndarray, str]:
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


def load_multi_npz(path: str | os.PathLike) -> MultiPersonDetections:
    """Read a multi-person keypoint file (ValueError naming the file and a missing key or bad array)."""
    kp, names, times, skeleton = _read_keypoints(path)
    if kp.ndim == 4:
        kp = kp[:, :, None]  # one person per camera and frame
    try:
        return MultiPersonDetections(keypoints=kp, camera_names=names, times_s=times, skeleton=skeleton)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def load_detections_npz(path: str | os.PathLike) -> Detections:
    """Read a single-person keypoint file written by :func:`gaitcap.acquisition.writers.save_detections_npz`."""
    kp, names, times, skeleton = _read_keypoints(path)
    try:
        return Detections(keypoints=kp, camera_names=names, times_s=times, skeleton=skeleton)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
