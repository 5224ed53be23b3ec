"""Board observations from a calibration recording: a trial MCAP written by the recorder, or a folder
with one sub-folder of images or one video per camera (see :mod:`gaitcap.acquisition.boards.sources`).

Frames are paired across cameras by time (:mod:`gaitcap.acquisition.boards.pairing`; by order when a
folder has no times), the pairs subsampled and searched for the board, views of a board that moved
between the cameras' exposures left out, and what was found summarised per camera
(:mod:`gaitcap.acquisition.boards.diagnosis`); then :func:`calibrate_from_recording` calibrates.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np
from gaitcap.acquisition.boards.detection import BoardConfig, BoardFind, make_board
from gaitcap.acquisition.boards.diagnosis import (
    CameraDetection,
    detection_table,
    too_few_positions_error,
    too_few_views_error,
)
from gaitcap.acquisition.boards.pairing import (
    MISSING,
    PairingConfig,
    default_tolerance_ns,
    pair_by_time,
    separate_moving,
)
from gaitcap.acquisition.boards.sources import TIMESTAMPS_FILE, folder_sources
from gaitcap.reconstruction.calibration import (
    BoardObservations,
    CalibrationConfig,
    CalibrationResult,
    calibrate_from_observations,
)
from gaitcap.reconstruction.calibration.still import merge_still_frames

log = logging.getLogger(__name__)

MAX_WORKERS = 8
PROBE_FRAMES = 8  # frames per camera searched with every printing variant when a fixed one finds nothing
Progress = Callable[[int, int | None], None]  # (images done, total images or None)


@dataclass(frozen=True)
class FrameSelection:
    """Which frame sets to search: every ``every``-th, at most ``max_frames`` of them (None = all)."""

    every: int = 1
    max_frames: int | None = None

    def __post_init__(self) -> None:
        if self.every < 1 or (self.max_frames is not None and self.max_frames < 1):
            raise ValueError(f"frame selection: every ({self.every}) and max_frames ({self.max_frames}) must be >= 1")


@dataclass(frozen=True, eq=False)
class BoardDetections:
    """Observations for the calibration, what was found per camera, and whether frames had times."""

    observations: BoardObservations
    cameras: tuple[CameraDetection, ...]
    board: BoardConfig
    timed: bool

    def table(self) -> str:
        return detection_table(self.cameras)

    @property
    def views_removed(self) -> dict[str, int]:
        """{camera: board views found but left out before calibration (smeared during the readout)}: the
        calibration counts them among the camera's views found (``calibrate_from_observations``)."""
        return {c.name: c.smeared for c in self.cameras if c.smeared}

    def positions(self) -> tuple[int, ...]:
        """Per camera: distinct board positions the calibration gets (a still board's frames merged)."""
        merged, _ = merge_still_frames(self.observations)
        return tuple(int(n) for n in merged.views().sum(1))

    def check(self, min_views: int) -> None:
        """ValueError naming each camera with fewer than ``min_views`` usable views, or distinct board
        positions, and what to change."""
        err = too_few_views_error(self.cameras, self.board, min_views)
        if err is None:
            err = too_few_positions_error(self.cameras, self.positions(), self.board, min_views)
        if err is not None:
            raise err


@dataclass(frozen=True, eq=False)
class _Camera:
    name: str
    times_ns: np.ndarray | None
    n_frames: int


def _mcap_cameras(path: Path) -> list[_Camera]:
    from gaitcap.acquisition.recording.reader import iter_frames

    stamps: dict[str, list[int]] = {}
    for frame in iter_frames(path):
        stamps.setdefault(frame.camera, []).append(frame.timestamp_ns)
    return [_Camera(c, np.asarray(t, dtype=np.int64), len(t)) for c, t in sorted(stamps.items())]


def _mcap_frames(path: Path, wanted: list[set[int]], names: list[str]) -> Iterator[tuple[int, int, np.ndarray]]:
    from gaitcap.acquisition.recording.reader import iter_frames

    count = dict.fromkeys(names, 0)
    col = {n: c for c, n in enumerate(names)}
    for frame in iter_frames(path):
        c, i = col[frame.camera], count[frame.camera]
        count[frame.camera] += 1
        if i in wanted[c]:
            img = cv2.imdecode(np.frombuffer(frame.jpeg, np.uint8), cv2.IMREAD_GRAYSCALE)
            if img is None:
                raise ValueError(f"camera {frame.camera} frame {frame.frame_id}: not a decodable image")
            yield c, i, img


def _frame_sets(cams: list[_Camera], pairing: PairingConfig, path: Path) -> tuple[np.ndarray, bool]:
    """(S, C) frame sets and whether they were paired by time (else by order: ValueError when ``pairing``
    asks for what only times allow)."""
    bare = [c.name for c in cams if c.times_ns is None or len(c.times_ns) != c.n_frames]
    flat = [c.name for c in cams if not bare and np.any(np.diff(c.times_ns) <= 0)]
    if flat:  # e.g. a container that gives every frame the same time: the times say nothing
        log.warning("frame times of cameras %s do not increase: frames paired by order", flat)
    if bare or flat:
        why = f"the frames of cameras {bare} carry no timestamps" if bare else \
            f"the frame times of cameras {flat} do not increase"
        _refuse_untimed(path, why, pairing)
        return pair_by_time([np.arange(c.n_frames, dtype=np.int64) for c in cams], 0), False
    times = [c.times_ns for c in cams]
    tol = int(pairing.tolerance_ms * 1e6) if pairing.tolerance_ms is not None else default_tolerance_ns(times)
    return pair_by_time(times, tol), True


def _refuse_untimed(path: Path, why: str, pairing: PairingConfig) -> None:
    """ValueError naming the pairing options set although frames without times are paired by order (they
    would be ignored), why, and what to do."""
    asked = pairing.asked()
    if not asked:
        return
    fix = f"add (or correct) a {TIMESTAMPS_FILE} beside the camera folders (columns camera, time_s) or "
    fix = fix if path.is_dir() else ""
    need, them = ("need", "them") if len(asked) > 1 else ("needs", "it")
    raise ValueError(f"{path}: {why}, so the cameras are paired by order and the board's motion in time is "
                     f"unknown: {' and '.join(asked)} {need} frame times; {fix}leave {them} out")


def _detect(frames: Iterator[tuple[int, int, np.ndarray]], board: BoardConfig, workers: int,
            progress: Progress | None) -> tuple[dict[tuple[int, int], BoardFind], dict[int, tuple[int, int]],
                                                dict[int, dict[str, int]]]:
    """Every frame searched: {(camera, index): find}, image sizes, and probes of other printing variants."""
    detector = make_board(board)
    free = replace(board, inverted=None, legacy_layout=None)
    prober = make_board(free) if free != board else None
    finds: dict[tuple[int, int], BoardFind] = {}
    sizes: dict[int, tuple[int, int]] = {}
    probes: dict[int, dict[str, int]] = {}
    probed: dict[int, int] = {}
    batch: list[tuple[int, int, np.ndarray]] = []

    def run(items):
        for (c, i, img), found in zip(items, pool.map(lambda b: detector.find(b[2]), items), strict=True):
            sizes.setdefault(c, (img.shape[1], img.shape[0]))
            finds[(c, i)] = found
            if prober is not None and found.corners is None and probed.get(c, 0) < PROBE_FRAMES:
                probed[c] = probed.get(c, 0) + 1
                alt = prober.find(img)
                if alt.corners is not None and alt.variant is not None:
                    key = alt.variant.describe()
                    probes.setdefault(c, {})[key] = probes.get(c, {}).get(key, 0) + 1
            if progress is not None:
                progress(len(finds), None)

    with ThreadPoolExecutor(max_workers=workers) as pool:
        for item in frames:
            batch.append(item)
            if len(batch) == 4 * workers:
                run(batch)
                batch = []
        run(batch)
    return finds, sizes, probes


def find_board_views(
    path: str | os.PathLike, *, board: BoardConfig = BoardConfig(), selection: FrameSelection = FrameSelection(),
    pairing: PairingConfig = PairingConfig(), progress: Progress | None = None, workers: int | None = None,
) -> BoardDetections:
    """Find the board in the selected frame sets of a recording (MCAP file or folder).

    ``workers`` threads run the detector (OpenCV releases the GIL); default: the CPU count, at most 8.
    """
    path = Path(path)
    if not path.exists():
        raise ValueError(f"recording {path} does not exist")
    if path.is_dir():
        sources = folder_sources(path)
        cams = [_Camera(s.name, s.times_ns, s.n_frames) for s in sources]
    else:
        cams = _mcap_cameras(path)
    if not cams or not any(c.n_frames for c in cams):
        raise ValueError(f"recording {path}: no camera frames in it")
    sets, timed = _frame_sets(cams, pairing, path)
    sets = sets[:: selection.every][: selection.max_frames]
    wanted = [set(sets[:, c][sets[:, c] != MISSING].tolist()) for c in range(len(cams))]
    names = [c.name for c in cams]
    if path.is_dir():
        frames = ((c, i, img) for c, s in enumerate(sources) for i, img in s.frames(wanted[c]))
    else:
        frames = _mcap_frames(path, wanted, names)
    finds, sizes, probes = _detect(frames, board, workers or min(os.cpu_count() or 1, MAX_WORKERS), progress)
    return _assemble(cams, sets, timed, finds, sizes, probes, board, pairing)


def _assemble(cams, sets, timed, finds, sizes, probes, board, pairing) -> BoardDetections:
    """Observations of the frame sets where any camera found the board (one empty set when none did)."""
    geometry = make_board(board).geometry

    def corners_of(c: int, i: int) -> np.ndarray | None:
        found = finds.get((c, i)) if i != MISSING else None
        return None if found is None else found.corners

    hit = [any(corners_of(c, int(i)) is not None for c, i in enumerate(s)) for s in sets]
    keep = np.flatnonzero(hit) if any(hit) else np.arange(min(1, len(sets)))
    corners = np.full((len(cams), len(keep), geometry.num_corners, 2), np.nan)
    cam_t = np.full((len(cams), len(keep)), np.nan)  # s (timed) or frame index
    for k, s in enumerate(keep):
        for c, i in enumerate(int(i) for i in sets[s]):
            found = corners_of(c, i)
            if found is not None:
                corners[c, k] = found
            if i != MISSING:
                cam_t[c, k] = cams[c].times_ns[i] * 1e-9 if timed else float(i)
    set_t = np.nanmedian(cam_t, axis=0) if cam_t.size else np.zeros(0)  # every set holds a frame
    times_s = set_t - np.nanmin(set_t) if timed and set_t.size else np.nanmin(cam_t, axis=0)
    corners, times_s, moving, smeared = separate_moving(corners, cam_t, times_s, pairing, timed=timed)
    missing = [c.name for i, c in enumerate(cams) if i not in sizes]
    if missing:
        raise ValueError(f"cameras {missing}: no frame could be read")
    obs = BoardObservations(tuple(c.name for c in cams), tuple(sizes[c] for c in range(len(cams))), corners,
                            geometry, np.nan_to_num(times_s))
    per_cam = tuple(
        CameraDetection.from_finds(cam.name, [f for (c, _), f in finds.items() if c == ci],
                                   min_corners=geometry.min_corners,
                                   moving=int(moving[ci]), smeared=int(smeared[ci]),
                                   probe=probes.get(ci))
        for ci, cam in enumerate(cams)
    )
    log.info("board found in %d of %d images (%s)", sum(c.with_board for c in per_cam), len(finds),
             "paired by time" if timed else "paired by order")
    return BoardDetections(obs, per_cam, board, timed)


def detect_recording(
    path: str | os.PathLike, *, board: BoardConfig = BoardConfig(), selection: FrameSelection = FrameSelection(),
    progress: Progress | None = None, workers: int | None = None,
) -> BoardObservations:
    """The board observations of a recording (see :func:`find_board_views`)."""
    return find_board_views(path, board=board, selection=selection, progress=progress, workers=workers).observations


def calibrate_from_recording(
    path: str | os.PathLike, *, board: BoardConfig = BoardConfig(), config: CalibrationConfig | None = None,
    selection: FrameSelection = FrameSelection(), pairing: PairingConfig = PairingConfig(),
    progress: Progress | None = None,
) -> CalibrationResult:
    """Detect the board in a recording and calibrate every camera in it (ValueError names the problem:
    per camera, what was found and what to change)."""
    config = config or CalibrationConfig()
    found = find_board_views(path, board=board, selection=selection, pairing=pairing, progress=progress)
    found.check(config.intrinsics.min_views)
    return calibrate_from_observations(found.observations, config=config, views_removed=found.views_removed)
