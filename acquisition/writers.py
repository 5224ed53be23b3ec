"""Writing the files that ``reconstruction/`` computes and reads: calibrations, keypoints,
walkway exports (read back by :mod:`gaitcap.acquisition.readers`). ``reconstruction/`` stays pure (it
builds the text or arrays and parses text, never reads or writes a file); every writer here goes through the one atomic writer, :mod:`gaitcap.acquisition.fileio`.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from gaitcap.acquisition.fileio import atomic_savez, atomic_write_text
from gaitcap.acquisition.readers import KEYS
from gaitcap.reconstruction.calibration_io import rig_to_text
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.gait.walkway import WalkwayTrial, walkway_csv_text
from gaitcap.reconstruction.keypoints import MultiViewKeypoints


def save_rig(rig: Rig, path: str | os.PathLike, *, metadata: dict[str, Any] | None = None) -> Path:
    """Write a calibration; the format follows the suffix (.toml: aniposelib, metres; .json: gaitcap, mm)."""
    path = Path(path)
    return atomic_write_text(path, rig_to_text(rig, suffix=path.suffix, metadata=metadata, where=str(path)))


def save_multi_npz(multi: MultiViewKeypoints, path: str | os.PathLike, **extra: np.ndarray) -> Path:
    """Write a multi-person keypoint file with its frame ids, camera timestamps and provenance, plus ``extra``
    arrays (e.g. ``detector``; read by :func:`gaitcap.acquisition.readers.load_multi_npz`)."""
    return atomic_savez(path, keypoints=multi.keypoints, camera_names=np.array(multi.camera_names),
                        times_s=multi.times_s, skeleton=np.array(multi.skeleton.name), frame_ids=multi.frame_ids,
                        timestamps_ns=multi.timestamps_ns, provenance=multi.provenance, **extra)


def save_detections_npz(detections: MultiViewKeypoints, path: str | os.PathLike, **extra: np.ndarray) -> Path:
    """Write one person's detections plus ``extra`` arrays (e.g. ``track_id``; read by
    :func:`gaitcap.acquisition.readers.load_detections_npz`)."""
    clash = sorted(set(extra) & set(KEYS))
    if clash:
        raise ValueError(f"extra arrays may not be named {clash}")
    return atomic_savez(path, keypoints=detections.one_person, camera_names=np.array(detections.camera_names),
                        times_s=detections.times_s, skeleton=np.array(detections.skeleton.name), **extra)


def write_walkway_csv(trials: Sequence[WalkwayTrial], path: str | os.PathLike) -> Path:
    """Write trials in the walkway CSV format (read by :func:`gaitcap.acquisition.readers.read_walkway_csv`)."""
    return atomic_write_text(path, walkway_csv_text(trials))
