"""Completion after Stop: every recorded frame without live keypoints, detected from the recording's images.

The live detector keeps up as far as it can; the recorder keeps every image. :func:`complete_keypoints`
reads the trial's JPEG images from its MCAP in one pass, sends each frame that has no live keypoints (none
received, or nobody found in it; or every frame, ``redetect_all``) to a
:class:`~gaitcap.acquisition.detectors.pool.DetectorPool` of the offline detector (built in each worker
process by a picklable factory; it may be heavier than the live one), and returns the complete keypoints with a :class:`CompletionReport`: per camera the frames recorded, detected
live, completed now, the corrupt images (named, skipped and counted; nothing else is lost) and the frames
still without keypoints; the detector; the provenance of every frame (live, completed or missing: the
codes of :mod:`gaitcap.reconstruction.keypoints`), which the keypoints carry too. :func:`save_completion`
stores both with the trial's files.

Frames are placed on the recording's frame grid by frame id (the image's MCAP sequence); a camera whose
frame counter restarted within the recording is placed by time, from its live keypoints' timestamps.
"""

from __future__ import annotations

import json
import logging
import os
import threading
import time
from collections.abc import Callable
from dataclasses import MISSING as MISSING_FIELD
from dataclasses import dataclass, field, fields, replace
from pathlib import Path

import numpy as np
from gaitcap.acquisition.detectors.base import DetectorConfig
from gaitcap.acquisition.detectors.pool import (
    DetectorPool,
    DetectResult,
    FrameTask,
    default_workers,
    shared_cores,
)
from gaitcap.acquisition.fileio import atomic_write_text
from gaitcap.acquisition.recording.reader import frame_times_s, iter_frames
from gaitcap.acquisition.writers import save_multi_npz
from gaitcap.reconstruction.keypoints import COMPLETED, LIVE, MISSING, MultiViewKeypoints

log = logging.getLogger(__name__)

KEYPOINTS_FILE = "keypoints_complete.npz"
REPORT_FILE = "completion.json"
QUEUED_PER_WORKER = 32  # frames read ahead of the workers (bounds memory: JPEGs wait in this process)
NAMED_AT_MOST = 50  # corrupt / missing frame ids named per camera in the report


@dataclass(frozen=True)
class CameraCompletion:
    """One camera: ``recorded`` images; of their frames ``live`` had live keypoints, ``completed`` were
    detected now; ``corrupt_frame_ids`` could not be decoded or detected (skipped); ``missing_frame_ids``
    are still without keypoints (corrupt, or lost with a worker that died); ``live_pass``: frames the live
    pass had detected (its coverage, whether or not they were detected again; None: its keypoints not read)."""

    camera: str
    recorded: int
    live: int
    completed: int
    corrupt_frame_ids: tuple[int, ...] = ()
    missing_frame_ids: tuple[int, ...] = ()
    live_pass: int | None = None

    @property
    def coverage(self) -> float:
        """Frames with keypoints / recorded images (0..1; 1 when nothing was recorded)."""
        return (self.live + self.completed) / self.recorded if self.recorded else 1.0

    def to_dict(self) -> dict:
        return {"recorded": self.recorded, "live": self.live, "completed": self.completed,
                "live_pass": self.live_pass,
                "live_coverage": round(self.live_pass / self.recorded, 4) if self.recorded and self.live_pass is not None
                else None,
                "coverage": round(self.coverage, 4), "corrupt": len(self.corrupt_frame_ids),
                "corrupt_frame_ids": list(self.corrupt_frame_ids[:NAMED_AT_MOST]),
                "missing": len(self.missing_frame_ids),
                "missing_frame_ids": list(self.missing_frame_ids[:NAMED_AT_MOST])}


@dataclass(frozen=True, eq=False)
class CompletionReport:
    """What the completion did. ``provenance``: (C, T) uint8 per camera and frame of ``frame_ids``:
    ``MISSING``, ``LIVE`` or ``COMPLETED`` (:mod:`gaitcap.reconstruction.keypoints`); ``seconds``: wall time
    of the completion (s)."""

    detector: str
    redetected_all: bool
    workers: int
    seconds: float
    cameras: tuple[CameraCompletion, ...]
    camera_names: tuple[str, ...]
    frame_ids: np.ndarray
    provenance: np.ndarray

    @property
    def complete(self) -> bool:
        """Every recorded image has keypoints."""
        return all(not c.missing_frame_ids for c in self.cameras)

    def to_dict(self) -> dict:
        return {"detector": self.detector, "redetected_all": self.redetected_all, "workers": self.workers,
                "seconds": round(self.seconds, 3), "complete": self.complete,
                "frames": {"recorded": sum(c.recorded for c in self.cameras),
                           "live": sum(c.live for c in self.cameras),
                           "completed": sum(c.completed for c in self.cameras),
                           "corrupt": sum(len(c.corrupt_frame_ids) for c in self.cameras),
                           "live_pass": (None if any(c.live_pass is None for c in self.cameras)
                                         else sum(c.live_pass for c in self.cameras))},
                "cameras": {c.camera: {**c.to_dict(), "completed_frame_ids": _runs(
                    self.frame_ids[self.provenance[i] == COMPLETED])} for i, c in enumerate(self.cameras)}}


def _runs(ids: np.ndarray) -> list[list[int]]:
    """Sorted frame ids as [[first, last], ...] runs of consecutive ids."""
    if ids.size == 0:
        return []
    cut = np.flatnonzero(np.diff(ids) != 1) + 1
    return [[int(r[0]), int(r[-1])] for r in np.split(ids, cut)]


class _Placer:
    """Where an image lands on the live keypoints' frame grid, and whether it has live keypoints there."""

    def __init__(self, recording: MultiViewKeypoints | None) -> None:
        self.rec = recording
        self.index = {} if recording is None else {c: i for i, c in enumerate(recording.camera_names)}
        self.by_time = {} if recording is None else {c: self._time_grid(c) for c in recording.restarts
                                                     if c in self.index}

    def _time_grid(self, camera: str) -> tuple[float, float]:
        """(offset ns, period ns): frame id = round((t - offset) / period) for a restarted camera."""
        stamps = self.rec.timestamps_ns
        ok = stamps >= 0
        period = float(np.median(np.diff(self.rec.times_s))) * 1e9 if self.rec.times_s.size > 1 else 1e9 / 30
        row = stamps[self.index[camera]]
        have = row >= 0
        ref = int(stamps[ok].min())
        offset = float(np.median(row[have] - ref - self.rec.frame_ids[have] * period)) if have.any() else 0.0
        return ref + offset, period

    def slot(self, camera: str, frame_id: int, timestamp_ns: int) -> int:
        if camera in self.by_time:
            offset, period = self.by_time[camera]
            return int(round((timestamp_ns - offset) / period))
        return int(frame_id)

    def has_live(self, camera: str, slot: int) -> bool:
        """Whether the live pass left keypoints of someone at this camera frame: a frame it detected and found
        nobody in is detected again (the offline detector, tracking through the frames around it, often finds
        the walker the live pass lost when it thinned its frames); where it finds nobody either, the frame stays
        live."""
        if self.rec is None or camera not in self.index:
            return False
        c, t = self.index[camera], slot - int(self.rec.frame_ids[0])
        return (0 <= t < self.rec.frame_ids.size and self.rec.timestamps_ns[c, t] >= 0
                and bool(np.any(self.rec.keypoints[c, t, :, :, 2] > 0)))


@dataclass
class _Collected:
    """The images seen and the detections received (filled by the pool's reader thread)."""

    images: dict[str, dict[int, int]] = field(default_factory=dict)  # camera -> {slot: timestamp ns}
    sent: dict[tuple[str, int, int], int] = field(default_factory=dict)  # (camera, frame id, stamp ns) -> slot
    found: dict[tuple[str, int], np.ndarray] = field(default_factory=dict)  # (camera, slot) -> (P, J, 3)
    corrupt: dict[str, list[int]] = field(default_factory=dict)  # camera -> frame ids
    lock: threading.Lock = field(default_factory=threading.Lock)

    def __call__(self, result: DetectResult) -> None:
        task = result.task
        with self.lock:
            slot = self.sent[(task.camera, task.frame_id, task.timestamp_ns)]
            if result.error is not None:
                self.corrupt.setdefault(task.camera, []).append(task.frame_id)
                log.warning("completion: %s skipped: %s", _frame_name(task.camera, task.frame_id), result.error)
            else:
                self.found[(result.task.camera, slot)] = result.people


def _frame_name(camera: str, frame_id: int) -> str:
    return f"camera {camera} frame {frame_id}"


def complete_keypoints(
    mcap_path: str | os.PathLike,
    recording: MultiViewKeypoints | None,
    detector_factory: Callable[[], object],
    *,
    detector_name: str,
    workers: int = 1,
    redetect_all: bool = False,
    max_batch: int = 4,
) -> tuple[MultiViewKeypoints, CompletionReport]:
    """Detect the recorded frames of ``mcap_path`` that have no keypoints in ``recording`` (its live
    keypoints, :func:`~gaitcap.acquisition.recording.reader.read_keypoints`; None when it has none), or
    all of them (``redetect_all``), with ``detector_factory()`` in ``workers`` processes (0: in this process).

    Returns the keypoints (live ones kept, the others detected; the grid widened to every recorded frame)
    and the report. ValueError when the live keypoints' skeleton is not the detector's (re-detect all)."""
    t0 = time.perf_counter()
    placer = _Placer(None if redetect_all else recording)
    got = _Collected()
    pool = (DetectorPool.of_processes(detector_factory, workers, got, max_batch=max_batch, max_pending=2**31)
            if workers > 0 else DetectorPool.in_process(detector_factory(), got, max_batch=max_batch,
                                                        max_pending=2**31))
    try:
        if recording is not None and not redetect_all and recording.skeleton.name != pool.skeleton:
            raise ValueError(f"{mcap_path}: the live keypoints are {recording.skeleton.name}, the completion detector "
                             f"{detector_name} gives {pool.skeleton}: re-detect every frame instead")
        _feed(mcap_path, placer, pool, got, max(1, workers))
        _drain(pool)
    finally:
        pool.close()
    keypoints, report = _assemble(recording if not redetect_all else None, got, pool.skeleton,
                                  detector_name=detector_name, redetect_all=redetect_all, workers=workers,
                                  live_pass=live_pass_counts(recording))
    report = _with_seconds(report, time.perf_counter() - t0)
    log.info("completion of %s with %s: %d frames recorded, %d live, %d completed, %d corrupt in %.1f s",
             mcap_path, detector_name, *(report.to_dict()["frames"][k] for k in ("recorded", "live", "completed",
                                                                                 "corrupt")), report.seconds)
    return keypoints, report


def _feed(mcap_path, placer: _Placer, pool: DetectorPool, got: _Collected, workers: int) -> None:
    """One pass over the recording's images: note each, send those without live keypoints to the pool."""
    for frame in iter_frames(mcap_path):
        slot = placer.slot(frame.camera, frame.frame_id, frame.timestamp_ns)
        with got.lock:
            got.images.setdefault(frame.camera, {})[slot] = frame.timestamp_ns
            if placer.has_live(frame.camera, slot):
                continue
            got.sent[(frame.camera, frame.frame_id, frame.timestamp_ns)] = slot
        while pool.queued() >= QUEUED_PER_WORKER * workers:
            if not pool.alive_workers():
                raise RuntimeError(f"{mcap_path}: every completion detector worker died")
            time.sleep(0.002)
        pool.submit(FrameTask(frame.camera, frame.frame_id, frame.timestamp_ns, time.time_ns(), frame.jpeg))


def _drain(pool: DetectorPool) -> None:
    while pool.busy():
        if not pool.alive_workers():
            raise RuntimeError("every completion detector worker died")
        time.sleep(0.01)


def _assemble(recording: MultiViewKeypoints | None, got: _Collected, skeleton: str, *, detector_name: str,
              redetect_all: bool, workers: int, live_pass: dict[str, int] | None
              ) -> tuple[MultiViewKeypoints, CompletionReport]:
    """The keypoints on one grid holding every live frame and recorded image, and the report
    (``live_pass``: {camera: frames the live pass detected}, a camera it never detected 0; None: not read)."""
    live_names = list(recording.camera_names) if recording is not None else []
    names = live_names + sorted(set(got.images) - set(live_names))
    slots = [s for per in got.images.values() for s in per]
    if recording is not None:
        slots += [int(recording.frame_ids[0]), int(recording.frame_ids[-1])]
    if not slots:
        raise ValueError("the recording holds no images and no keypoints")
    first, last = min(slots), max(slots)
    frame_ids = np.arange(first, last + 1)
    joints = _joints(recording, got)
    most = max([len(p) for p in got.found.values()] + ([recording.shape[2]] if recording is not None else []))
    people = np.full((len(names), frame_ids.size, most, joints, 3), np.nan)
    people[..., 2] = 0.0
    stamps = np.full((len(names), frame_ids.size), -1, dtype=np.int64)
    prov = np.zeros((len(names), frame_ids.size), dtype=np.uint8)
    if recording is not None:
        t0 = int(recording.frame_ids[0]) - first
        span = slice(t0, t0 + recording.frame_ids.size)
        c = len(live_names)
        people[:c, span, : recording.shape[2]] = recording.keypoints
        stamps[:c, span] = recording.timestamps_ns
        prov[:c, span] = recording.provenance
    for (cam, slot), found in got.found.items():
        c, t = names.index(cam), slot - first
        if not redetect_all and prov[c, t] == LIVE and not _anyone(found):
            continue  # the live pass found nobody here and neither did the completion: the frame stays live
        people[c, t, : len(found)] = found
        stamps[c, t] = got.images[cam][slot]
        prov[c, t] = COMPLETED
    out = MultiViewKeypoints(people, tuple(names), frame_times_s(stamps), skeleton, frame_ids=frame_ids,
                             timestamps_ns=stamps, provenance=prov,
                             restarts=dict(recording.restarts) if recording is not None else {},
                             ignored=dict(recording.ignored) if recording is not None else {})
    cams = tuple(replace(_camera_row(cam, names.index(cam), got, prov, first),
                         live_pass=None if live_pass is None else live_pass.get(cam, 0)) for cam in names)
    return out, CompletionReport(detector_name, redetect_all, workers, 0.0, cams, tuple(names), frame_ids, prov)


def live_pass_counts(recording: MultiViewKeypoints | None) -> dict[str, int] | None:
    """{camera: frames the live pass detected} (None without its keypoints)."""
    if recording is None:
        return None
    return {cam: int((recording.provenance[c] == LIVE).sum()) for c, cam in enumerate(recording.camera_names)}


def _anyone(found: np.ndarray) -> bool:
    """Whether detections (P, J, 3) hold anyone: a joint with confidence above 0."""
    return bool(found.size) and bool(np.any(np.nan_to_num(found[..., 2]) > 0))


def _joints(recording: MultiViewKeypoints | None, got: _Collected) -> int:
    found = next((p.shape[1] for p in got.found.values() if p.ndim == 3 and p.shape[1]), None)
    if found is None and recording is not None:
        return recording.shape[3]
    if found is None:
        raise ValueError("no keypoints: nothing was detected live and no recorded image could be detected")
    return found


def _camera_row(cam: str, c: int, got: _Collected, prov: np.ndarray, first: int) -> CameraCompletion:
    recorded = np.array(sorted(got.images.get(cam, {})), dtype=np.int64)
    on = prov[c, recorded - first] if recorded.size else np.zeros(0, np.uint8)
    return CameraCompletion(cam, int(recorded.size), int((on == LIVE).sum()), int((on == COMPLETED).sum()),
                            tuple(sorted(got.corrupt.get(cam, []))), tuple(int(f) for f in recorded[on == MISSING]))


def _with_seconds(report: CompletionReport, seconds: float) -> CompletionReport:
    return replace(report, seconds=seconds)


@dataclass(frozen=True)
class CompletionSettings:
    """How a trial is completed: ``detector``, the offline detector's typed config (its ``build`` runs in each
    worker process; e.g. ``MediaPipeConfig(model="heavy")`` or an ``OnnxConfig``); ``workers`` processes (None:
    one per CPU core; 0: in this process); ``max_batch`` frames a worker takes at once; ``redetect_all``: detect
    every recorded frame, the live ones too (each camera tracked through all its frames, as ``gaitcap detect``
    does: the final keypoints do not depend on what the live pass caught; costs the live frames again)."""

    detector: DetectorConfig
    workers: int | None = None
    max_batch: int = 4
    redetect_all: bool = False

    @property
    def detector_name(self) -> str:
        """The detector kind and the config fields that differ from their defaults."""
        changed = [f"{f.name}={getattr(self.detector, f.name)}" for f in fields(self.detector)
                   if f.default is not MISSING_FIELD and getattr(self.detector, f.name) != f.default]
        return " ".join([self.detector.kind, *changed])


def complete_with(mcap_path: str | os.PathLike, recording: MultiViewKeypoints | None,
                  settings: CompletionSettings) -> tuple[MultiViewKeypoints, CompletionReport]:
    """:func:`complete_keypoints` with ``settings`` (the one processing path's completion step)."""
    workers = default_workers() if settings.workers is None else settings.workers
    detector = shared_cores(settings.detector, workers)
    return complete_keypoints(mcap_path, recording, detector.build, detector_name=settings.detector_name,
                              workers=workers, max_batch=settings.max_batch, redetect_all=settings.redetect_all)


def complete_trial(mcap_path: str | os.PathLike, recording: MultiViewKeypoints | None, folder: str | os.PathLike,
                   settings: CompletionSettings) -> tuple[MultiViewKeypoints, CompletionReport, CompletionFiles]:
    """:func:`complete_with`, then :func:`save_completion` into the trial's ``folder``."""
    keypoints, report = complete_with(mcap_path, recording, settings)
    return keypoints, report, save_completion(folder, keypoints, report)


@dataclass(frozen=True)
class CompletionFiles:
    """The files :func:`save_completion` wrote: ``keypoints`` (.npz) and ``report`` (.json)."""

    keypoints: Path
    report: Path

    def to_dict(self) -> dict:
        return {"keypoints": str(self.keypoints), "report": str(self.report)}


def save_completion(folder: str | os.PathLike, keypoints: MultiViewKeypoints, report: CompletionReport
                    ) -> CompletionFiles:
    """Store the complete keypoints with their provenance and the report in the trial's ``folder``, each file
    written whole or not at all.

    ``keypoints_complete.npz`` is a multi-person keypoint file (``save_multi_npz``: ``keypoints`` (C, T, P,
    J, 3), ``camera_names``, ``times_s``, ``skeleton``, ``frame_ids`` (T,), ``timestamps_ns`` (C, T) and
    ``provenance`` (C, T: 0 missing, 1 live, 2 completed); ``load_multi_npz`` and ``gaitcap reconstruct``
    read it) plus ``detector``; ``completion.json`` is :meth:`CompletionReport.to_dict`."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    npz = save_multi_npz(keypoints, folder / KEYPOINTS_FILE, detector=np.array(report.detector))
    js = atomic_write_text(folder / REPORT_FILE, json.dumps(report.to_dict(), indent=1))
    return CompletionFiles(npz, js)
