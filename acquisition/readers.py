"""Reading the files that ``reconstruction/`` parses: calibrations, keypoint NPZ files, walkway exports.
The counterpart of :mod:`gaitcap.acquisition.writers`; ``reconstruction/`` reads and writes no file (it
parses the text or arrays handed to it). Every error names the file.

Keypoint NPZ files: several people per camera and frame in, one chosen person out. Multi-person file
keys: ``keypoints`` (C, T, P, J, 3) x px, y px, confidence; ``camera_names`` (C,) str; ``times_s`` (T,);
``skeleton`` (str). A single-person file has ``keypoints`` (C, T, J, 3) and the same other keys, plus
whatever extra arrays the writer adds (e.g. ``track_id``). One reader of these files,
:func:`read_keypoint_arrays`, for the loaders here and for ``gaitcap process`` on an NPZ
(:mod:`gaitcap.acquisition.importers.keypoint_files`, where ``times_s`` and ``skeleton`` may be left out and the
camera names may be under ``cameras``).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import NamedTuple

import numpy as np
from gaitcap.reconstruction.calibration_io import rig_from_text
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.gait.walkway import WalkwayTrial, walkway_from_csv_text
from gaitcap.reconstruction.keypoints import MultiViewKeypoints

KEYS = ("keypoints", "camera_names", "times_s", "skeleton")
FRAME_FACTS = ("frame_ids", "timestamps_ns", "provenance")  # optional in a multi-person keypoint file


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


class KeypointArrays(NamedTuple):
    """The arrays of a keypoint NPZ file (float64 keypoints, as laid out in the file)."""

    keypoints: np.ndarray  # (C, T, J, 3) or (C, T, P, J, 3)
    camera_names: tuple[str, ...]
    times_s: np.ndarray | None  # (T,); None when left out (only if allowed)
    skeleton: str | None  # None when left out (only if allowed)


def read_keypoint_arrays(path: str | os.PathLike, *, optional: tuple[str, ...] = ()) -> KeypointArrays:
    """Read a keypoint NPZ file: camera names under ``camera_names`` (or ``cameras``); ``optional``: of
    ``times_s`` and ``skeleton``, those that may be left out. FileNotFoundError or ValueError naming the file
    and every missing array, a bad shape, a camera count that differs, times not one per frame, or the
    camera with infinite keypoints."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"keypoint file {path} does not exist")
    with np.load(path, allow_pickle=False) as data:
        name_key = next((k for k in ("camera_names", "cameras") if k in data.files), None)
        missing = [k for k in KEYS if k not in optional
                   and (name_key is None if k == "camera_names" else k not in data.files)]
        if missing:
            also = " (camera names may also be under 'cameras')" if "camera_names" in missing else ""
            raise ValueError(f"{path}: missing arrays {missing}{also} (has {sorted(data.files)})")
        kp = np.asarray(data["keypoints"], dtype=np.float64)
        names = tuple(str(n) for n in data[name_key])
        times = np.asarray(data["times_s"], dtype=np.float64).reshape(-1) if "times_s" in data.files else None
        skeleton = str(data["skeleton"]) if "skeleton" in data.files else None
    if kp.ndim not in (4, 5) or kp.shape[-1] != 3:
        raise ValueError(f"{path}: keypoints must be (C, T, J, 3) or (C, T, P, J, 3), got {kp.shape}")
    if len(names) != kp.shape[0]:
        raise ValueError(f"{path}: {len(names)} camera names for {kp.shape[0]} cameras in keypoints")
    if times is not None and times.shape != (kp.shape[1],):
        raise ValueError(f"{path}: times_s: expected {kp.shape[1]} times (one per frame), got {times.shape[0]}")
    if np.isinf(kp).any():
        raise ValueError(f"{path}: keypoints of camera {names[int(np.argwhere(np.isinf(kp))[0, 0])]!r} are infinite")
    return KeypointArrays(kp, names, times, skeleton)


def load_multi_npz(path: str | os.PathLike) -> MultiViewKeypoints:
    """Read a multi-person keypoint file, with its :data:`FRAME_FACTS` where it has them (ValueError naming
    the file and a missing key or bad array)."""
    kp, names, times, skeleton = read_keypoint_arrays(path)
    if kp.ndim == 4:
        kp = kp[:, :, None]  # one person per camera and frame
    with np.load(path, allow_pickle=False) as data:
        facts = {k: data[k] for k in FRAME_FACTS if k in data.files}
    try:
        return MultiViewKeypoints(kp, names, times, skeleton, **facts)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def load_detections_npz(path: str | os.PathLike) -> MultiViewKeypoints:
    """Read a single-person keypoint file written by :func:`gaitcap.acquisition.writers.save_detections_npz`."""
    kp, names, times, skeleton = read_keypoint_arrays(path)
    try:
        return MultiViewKeypoints.of_one_person(keypoints=kp, camera_names=names, times_s=times, skeleton=skeleton)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
