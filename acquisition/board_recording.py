"""Board observations from a calibration recording: a trial MCAP written by the recorder, or a folder
with one sub-folder of images (``FOLDER/cam01/000123.png``) or one video (``FOLDER/cam01.mp4``) per
camera. Frames are matched across cameras by frame id (MCAP) or by order (folders), subsampled, and
searched for the board; then :func:`calibrate_from_recording` calibrates.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from gaitcap.acquisition.board import BoardConfig, make_board
from gaitcap.reconstruction.calibration import (
    BoardObservations,
    CalibrationConfig,
    CalibrationResult,
    calibrate_from_observations,
)

log = logging.getLogger(__name__)

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
VIDEO_SUFFIXES = (".mp4", ".avi", ".mkv", ".mov")

MAX_WORKERS = 8
Progress = Callable[[int, int | None], None]  # (images done, total images or None)


@dataclass(frozen=True)
class FrameSelection:
    """Which frames to search: every ``every``-th frame, at most ``max_frames`` of them (None = all)."""

    every: int = 1
    max_frames: int | None = None

    def __post_init__(self) -> None:
        if self.every < 1 or (self.max_frames is not None and self.max_frames < 1):
            raise ValueError(f"frame selection: every ({self.every}) and max_frames ({self.max_frames}) must be >= 1")


def _gray(data: bytes | np.ndarray, what: str) -> np.ndarray:
    if isinstance(data, bytes | bytearray):
        img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise ValueError(f"{what}: not a decodable image")
        return img
    return cv2.cvtColor(data, cv2.COLOR_BGR2GRAY) if data.ndim == 3 else data


def _folder_sources(folder: Path) -> dict[str, list[Path] | Path]:
    sources: dict[str, list[Path] | Path] = {}
    for entry in sorted(folder.iterdir()):
        if entry.is_dir():
            images = sorted(p for p in entry.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
            if images:
                sources[entry.name] = images
        elif entry.suffix.lower() in VIDEO_SUFFIXES:
            sources[entry.stem] = entry
    if not sources:
        raise ValueError(
            f"{folder}: no camera images or videos found; expected FOLDER/<camera>/*.png|jpg or FOLDER/<camera>.mp4"
        )
    return sources


def _video_frames(path: Path) -> Iterator[np.ndarray]:
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        raise ValueError(f"{path}: cannot open the video")
    try:
        while True:
            ok, frame = cap.read()
            if not ok:
                return
            yield frame
    finally:
        cap.release()


def _iter_folder(folder: Path, sel: FrameSelection) -> Iterator[tuple[str, int, int | None, np.ndarray]]:
    """(camera, frame index, None, grey image) for the selected frames of every camera."""
    for cam, src in _folder_sources(folder).items():
        frames = iter(src) if isinstance(src, list) else _video_frames(src)
        for i, item in enumerate(frames):
            if sel.max_frames is not None and i >= sel.every * sel.max_frames:
                break
            if i % sel.every:
                continue
            if isinstance(item, Path):
                img = cv2.imread(str(item), cv2.IMREAD_GRAYSCALE)
                if img is None:
                    raise ValueError(f"{item}: not a readable image")
            else:
                img = _gray(item, f"{src} frame {i}")
            yield cam, i, None, img


def _iter_mcap(path: Path, sel: FrameSelection) -> Iterator[tuple[str, int, int | None, np.ndarray]]:
    """(camera, frame id, timestamp ns, grey image) for the selected frames."""
    from gaitcap.acquisition.recording.reader import iter_frames

    first: int | None = None
    for frame in iter_frames(path):
        first = frame.frame_id if first is None else first
        k = frame.frame_id - first
        if k % sel.every or (sel.max_frames is not None and k >= sel.every * sel.max_frames):
            continue
        yield frame.camera, frame.frame_id, frame.timestamp_ns, _gray(frame.jpeg, f"camera {frame.camera} frame {frame.frame_id}")


def _batches(items: Iterator, size: int) -> Iterator[list]:
    batch = []
    for item in items:
        batch.append(item)
        if len(batch) == size:
            yield batch
            batch = []
    if batch:
        yield batch


def detect_recording(
    path: str | os.PathLike, *, board: BoardConfig = BoardConfig(), selection: FrameSelection = FrameSelection(),
    progress: Progress | None = None, workers: int | None = None,
) -> BoardObservations:
    """Find the board in the selected frames of every camera of a recording (MCAP file or folder).

    ``workers`` threads run the detector (OpenCV releases the GIL); default: the CPU count, at most 8.
    """
    path = Path(path)
    if not path.exists():
        raise ValueError(f"recording {path} does not exist")
    detector = make_board(board)
    frames = _iter_folder(path, selection) if path.is_dir() else _iter_mcap(path, selection)
    found: dict[tuple[str, int], np.ndarray] = {}
    sizes: dict[str, tuple[int, int]] = {}
    stamps: dict[int, int] = {}
    done = 0
    workers = workers or min(os.cpu_count() or 1, MAX_WORKERS)
    with ThreadPoolExecutor(max_workers=workers) as pool:
        for batch in _batches(frames, 4 * workers):
            for (cam, frame_id, stamp_ns, img), corners in zip(batch, pool.map(lambda b: detector.detect(b[3]), batch),
                                                               strict=True):
                sizes.setdefault(cam, (img.shape[1], img.shape[0]))
                if stamp_ns is not None:
                    stamps.setdefault(frame_id, stamp_ns)
                if corners is not None:
                    found[(cam, frame_id)] = corners
                done += 1
                if progress is not None:
                    progress(done, None)
    if not sizes:
        raise ValueError(f"recording {path}: no camera frames in it")
    cams = sorted(sizes)
    frame_ids = sorted({f for _, f in found}) or [0]
    corners = np.full((len(cams), len(frame_ids), detector.geometry.num_corners, 2), np.nan)
    col = {f: i for i, f in enumerate(frame_ids)}
    for (cam, f), c in found.items():
        corners[cams.index(cam), col[f]] = c
    log.info("board found in %d of %d images", len(found), done)
    if stamps and found:  # recorder timestamps; folders have none, so times are frame indices
        times_s = (np.array([stamps[f] for f in frame_ids]) - min(stamps.values())) * 1e-9
    else:
        times_s = np.asarray(frame_ids, dtype=np.float64)
    return BoardObservations(tuple(cams), tuple(sizes[c] for c in cams), corners, detector.geometry, times_s)


def calibrate_from_recording(
    path: str | os.PathLike, *, board: BoardConfig = BoardConfig(), config: CalibrationConfig | None = None,
    selection: FrameSelection = FrameSelection(), progress: Progress | None = None,
) -> CalibrationResult:
    """Detect the board in a recording and calibrate every camera in it (ValueError names the problem)."""
    obs = detect_recording(path, board=board, selection=selection, progress=progress)
    return calibrate_from_observations(obs, config=config)
