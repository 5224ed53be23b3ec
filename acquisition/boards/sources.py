"""The cameras of a board recording and each frame's time, read before any frame is searched.

A recording is a trial MCAP (the recorder's timestamps), or a folder with one sub-folder of images
(``FOLDER/cam01/000123.png``) or one video (``FOLDER/cam01.mp4``) per camera. A folder's frame times
come from a ``timestamps.csv`` beside them when there is one (columns: ``camera`` or ``cam_id``, a time
``time_s`` / ``frame_time`` in s or ``time_ns`` / ``timestamp_ns`` in ns, optionally ``frame`` /
``frame_index``; rows per camera in frame order), else from the video container (each frame's
presentation time; this assumes the videos started together). Image folders without a timestamps file
have no times, and neither has a camera whose times do not increase: then all frames are matched by
order.
"""

from __future__ import annotations

import csv
import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from gaitcap.acquisition.video_detect import VIDEO_SUFFIXES

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
TIMESTAMPS_FILE = "timestamps.csv"
_TIME_COLUMNS = {"time_s": 1e9, "frame_time": 1e9, "time_ns": 1.0, "timestamp_ns": 1.0}
_CAMERA_COLUMNS = ("camera", "cam_id", "port")
_FRAME_COLUMNS = ("frame", "frame_index")


@dataclass(frozen=True, eq=False)
class CameraSource:
    """One camera: where its frames are and their times (ns; None when the source has none)."""

    name: str
    path: Path | tuple[Path, ...]
    times_ns: np.ndarray | None
    n_frames: int

    def frames(self, wanted: set[int]) -> Iterator[tuple[int, np.ndarray]]:
        """(index, grey image) for the wanted frame indices, in order."""
        if isinstance(self.path, tuple):
            for i in sorted(wanted):
                img = cv2.imread(str(self.path[i]), cv2.IMREAD_GRAYSCALE)
                if img is None:
                    raise ValueError(f"{self.path[i]}: not a readable image")
                yield i, img
            return
        yield from _video_frames(self.path, wanted)


def _video_frames(path: Path, wanted: set[int]) -> Iterator[tuple[int, np.ndarray]]:
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        raise ValueError(f"{path}: cannot open the video")
    last = max(wanted, default=-1)
    try:
        for i in range(last + 1):
            if i not in wanted:
                if not cap.grab():
                    return
                continue
            ok, frame = cap.read()
            if not ok:
                return
            yield i, cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY) if frame.ndim == 3 else frame
    finally:
        cap.release()


def _container_times_ns(path: Path) -> np.ndarray:
    """Each frame's presentation time from the video container, ns (one pass without decoding to RGB)."""
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        raise ValueError(f"{path}: cannot open the video")
    times = []
    try:
        while cap.grab():
            times.append(cap.get(cv2.CAP_PROP_POS_MSEC))
    finally:
        cap.release()
    return np.rint(np.asarray(times, dtype=np.float64) * 1e6).astype(np.int64)


def _camera_key(value: str, names: list[str]) -> str | None:
    """The camera a timestamps row names: the name itself, or the camera whose name ends in that number."""
    if value in names:
        return value
    if value.isdigit():
        for name in names:
            m = re.search(r"(\d+)$", name)
            if m and int(m.group(1)) == int(value):
                return name
    return None


def read_timestamps_csv(path: Path, names: list[str]) -> dict[str, np.ndarray]:
    """{camera: frame times ns in frame order} from a timestamps CSV (ValueError names the bad column)."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError(f"{path}: no rows")
    cols = rows[0].keys()
    cam_col = next((c for c in _CAMERA_COLUMNS if c in cols), None)
    time_col = next((c for c in _TIME_COLUMNS if c in cols), None)
    if cam_col is None or time_col is None:
        raise ValueError(f"{path}: needs a camera column ({'/'.join(_CAMERA_COLUMNS)}) and a time column "
                         f"({'/'.join(_TIME_COLUMNS)}); found {sorted(cols)}")
    frame_col = next((c for c in _FRAME_COLUMNS if c in cols), None)
    per_cam: dict[str, list[tuple[float, float]]] = {}
    for k, row in enumerate(rows):
        cam = _camera_key(row[cam_col].strip(), names)
        if cam is None:
            raise ValueError(f"{path}: row {k + 2}: camera {row[cam_col]!r} is none of {names}")
        order = float(row[frame_col]) if frame_col else float(k)
        per_cam.setdefault(cam, []).append((order, float(row[time_col]) * _TIME_COLUMNS[time_col]))
    return {cam: np.rint([t for _, t in sorted(v)]).astype(np.int64) for cam, v in per_cam.items()}


def folder_sources(folder: Path) -> list[CameraSource]:
    """Every camera of a recording folder, with frame times where the folder has them."""
    found: dict[str, Path | tuple[Path, ...]] = {}
    for entry in sorted(folder.iterdir()):
        if entry.is_dir():
            images = tuple(sorted(p for p in entry.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES))
            if images:
                found[entry.name] = images
        elif entry.suffix.lower() in VIDEO_SUFFIXES:
            found[entry.stem] = entry
    if not found:
        raise ValueError(
            f"{folder}: no camera images or videos found; expected FOLDER/<camera>/*.png|jpg or FOLDER/<camera>.mp4"
        )
    stamps = read_timestamps_csv(folder / TIMESTAMPS_FILE, list(found)) if (folder / TIMESTAMPS_FILE).exists() else {}
    sources = []
    for name, path in found.items():
        times = stamps.get(name)
        if times is None and isinstance(path, Path):
            times = _container_times_ns(path)
        n = len(path) if isinstance(path, tuple) else (len(times) if times is not None else 0)
        if times is not None and len(times) != n and isinstance(path, tuple):
            raise ValueError(f"{folder / TIMESTAMPS_FILE}: camera {name!r} has {len(times)} times for {n} images")
        sources.append(CameraSource(name, path, times, n))
    if stamps and any(s.name not in stamps for s in sources):
        missing = [s.name for s in sources if s.name not in stamps]
        raise ValueError(f"{folder / TIMESTAMPS_FILE}: no times for cameras {missing}")
    return sources
