"""A pool of detector workers, frames routed by camera (the live detector node's and the completion of a
trial's keypoints after Stop).

Each worker holds its own model interpreter: a process (:meth:`DetectorPool.of_processes`, the detector
built in the process by a picklable factory such as a detector config's ``build``) or, for a detector
object already built, one thread (:meth:`DetectorPool.in_process`). A camera's frames always go to the
same worker while that worker lives, so per-camera tracking keeps working; a new camera goes to the worker
with the fewest cameras. A worker takes up to ``max_batch`` frames at once and hands them to the detector's
``detect_batch`` when it has one (a batched ONNX model), else detects them one by one.

Each worker has a bounded queue in this process (``max_pending`` frames); when it is full the oldest frame
is skipped and counted for its camera (so is a frame older than ``max_age_s`` when its turn comes; and a live
pool, one with ``max_age_s``, behind by more than a few frames per camera detects only every 2nd, 4th or 8th
frame id, the same ones on every camera), so live keypoints never lag without bound (the recorder still
records every image). At most ``max_inflight`` frames are with a worker at once. A worker process that
dies is noticed at once (its process sentinel): its cameras move to the workers left, its queued frames
with them; the frames it held are counted as ``lost`` for their cameras. Results reach ``on_result``
(:class:`DetectResult`) on the pool's reader thread. A dead worker process is replaced after a second (at
most ``MAX_RESPAWNS`` times) and takes cameras from the busiest workers.
"""

from __future__ import annotations

import collections
import dataclasses
import functools
import logging
import multiprocessing
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from multiprocessing.connection import Connection, wait

import numpy as np

log = logging.getLogger(__name__)

START_TIMEOUT_S = 120.0
RESPAWN_DELAY_S = 1.0  # a dead worker is replaced after this long
MAX_RESPAWNS = 20  # a detector that keeps crashing is not restarted for ever
THIN_AFTER = 15  # frames queued per camera (0.5 s at 30 fps) before frame ids are thinned out (live pools)
MAX_STRIDE = 8


def default_workers() -> int:
    """One worker per CPU core this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def shared_cores(config, workers: int):
    """``config`` (a detector's typed config) as each of ``workers`` pool processes runs it: a detector with
    interpreter threads (a ``num_threads`` field) left at its default gets ``max(1, cores // workers)`` of
    them, so the pool's processes use each core once (two TFLite threads in each of one process per core cost
    7-8 % more CPU a frame: ``bench/completion_cpu.py``); a value set by the user is kept."""
    field_ = next((f for f in dataclasses.fields(config) if f.name == "num_threads"), None)
    if field_ is None or config.num_threads != field_.default or workers < 1:
        return config
    return replace(config, num_threads=max(1, default_workers() // workers))


@dataclass(frozen=True)
class FrameTask:
    """One frame to detect: the JPEG as it came, its camera timestamp (ns) and the camera node's send
    time (wall clock ns, for the detector's lag)."""

    camera: str
    frame_id: int
    timestamp_ns: int
    sent_ns: int
    jpeg: bytes
    queued_ns: int = 0  # monotonic clock of this host when the pool took it (the age limit: no clock skew)


@dataclass(frozen=True)
class DetectResult:
    """A frame's keypoints (P, J, 3) px / px / confidence, or ``error`` (people None); ``detector_ms``: the
    model's time for this frame (a batch's time shared out); ``worker``: which worker detected it."""

    task: FrameTask
    people: np.ndarray | None
    detector_ms: float
    worker: int
    error: str | None = None


def _detect_all(detector, tasks: list[FrameTask]) -> list[tuple[np.ndarray | None, float, str | None]]:
    """Decode and detect ``tasks``; a frame that fails (corrupt JPEG, model error) fails alone."""
    from gaitcap.acquisition.encoding import decode_jpeg

    images, good, out = [], [], [None] * len(tasks)
    for i, t in enumerate(tasks):
        try:
            images.append(decode_jpeg(t.jpeg, what=f"camera {t.camera} frame {t.frame_id}"))
            good.append(i)
        except Exception as exc:  # a corrupt image is that frame's failure
            out[i] = (None, 0.0, f"{type(exc).__name__}: {exc}")
    batched = getattr(detector, "detect_batch", None)
    if batched is not None and len(good) > 1:
        t0 = time.perf_counter()
        try:
            found = batched(images, cameras=[tasks[i].camera for i in good],
                            frame_ids=[tasks[i].frame_id for i in good],
                            timestamps_ns=[tasks[i].timestamp_ns for i in good])
            ms = (time.perf_counter() - t0) * 1e3 / len(good)
            for i, people in zip(good, found, strict=True):
                out[i] = (np.asarray(people, dtype=np.float64), ms, None)
            return out
        except Exception as exc:  # the batch failed: try its frames one by one
            log.warning("batched detection of %d frames failed (%s); detecting them one by one", len(good), exc)
    for i, image in zip(good, images, strict=True):
        t = tasks[i]
        t0 = time.perf_counter()
        try:
            people = detector.detect(image, camera=t.camera, frame_id=t.frame_id, timestamp_ns=t.timestamp_ns)
            out[i] = (np.asarray(people, dtype=np.float64), (time.perf_counter() - t0) * 1e3, None)
        except Exception as exc:  # one bad frame must not stop the worker
            out[i] = (None, 0.0, f"{type(exc).__name__}: {exc}")
    return out


def serve(detector, conn: Connection, index: int, max_batch: int) -> None:
    """A worker's loop: receive frames on ``conn`` (None ends it), send back a :class:`DetectResult` each."""
    ending = False
    while not ending:
        first = conn.recv()
        if first is None:
            return
        batch = [first]
        while len(batch) < max_batch and conn.poll(0):
            nxt = conn.recv()
            if nxt is None:
                ending = True
                break
            batch.append(nxt)
        for task, (people, ms, error) in zip(batch, _detect_all(detector, batch), strict=True):
            conn.send(DetectResult(task, people, ms, index, error))


def _thread_main(detector, conn: Connection, max_batch: int) -> None:
    try:
        serve(detector, conn, 0, max_batch)
    except (EOFError, OSError):  # the pool closed its end
        return


def _process_main(factory: Callable[[], object], conn: Connection, index: int, max_batch: int) -> None:
    """A worker process: build the detector, say ready (its skeleton) or why not, then serve."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole group: the parent closes the pool
    logging.basicConfig(level=logging.INFO, format=f"%(asctime)s detector worker {index}: %(message)s")
    try:
        detector = factory()
    except Exception as exc:  # reported to the parent, which names the worker
        conn.send(("error", f"{type(exc).__name__}: {exc}"))
        return
    conn.send(("ready", detector.skeleton.name))
    try:
        serve(detector, conn, index, max_batch)
    except (EOFError, OSError):  # the parent went away
        return


@dataclass
class _Worker:
    index: int
    conn: Connection
    process: multiprocessing.process.BaseProcess | None = None
    thread: threading.Thread | None = None
    alive: bool = True
    cameras: set[str] = field(default_factory=set)
    pending: collections.deque = field(default_factory=collections.deque)
    inflight: dict[tuple[str, int], FrameTask] = field(default_factory=dict)

    @property
    def name(self) -> str:
        return f"worker {self.index}" + (f" (pid {self.process.pid})" if self.process is not None else "")


@dataclass
class PoolCounts:
    """Per camera: frames ``skipped`` (a full queue dropped them) and ``lost`` (held by a worker that died)."""

    skipped: collections.Counter = field(default_factory=collections.Counter)
    lost: collections.Counter = field(default_factory=collections.Counter)


class DetectorPool:
    """Detector workers with frames routed by camera (see the module docstring)."""

    def __init__(self, workers: list[_Worker], skeleton: str, on_result: Callable[[DetectResult], None] | None, *,
                 max_pending: int, max_inflight: int, max_age_s: float | None = None) -> None:
        if max_pending < 1 or max_inflight < 1 or (max_age_s is not None and max_age_s <= 0):
            raise ValueError("max_pending and max_inflight must be >= 1, max_age_s > 0")
        self.max_age_ns = None if max_age_s is None else int(max_age_s * 1e9)
        self.thin = max_age_s is not None  # a live pool keeps up by common frames; an offline one detects all
        self.skeleton = skeleton
        self._workers = workers
        self._size = len(workers)
        self._next_index = len(workers)
        self._respawn: Callable[[int], _Worker] | None = None  # set by of_processes
        self.respawned = 0
        self.on_result = on_result
        self.max_pending, self.max_inflight = max_pending, max_inflight
        self.counts = PoolCounts()
        self._route: dict[str, _Worker] = {}
        self._cond = threading.Condition()
        self._closed = False
        self._senders = [threading.Thread(target=self._send_loop, args=(w,), daemon=True, name=f"pool-send-{w.index}")
                         for w in workers]
        self._reader = threading.Thread(target=self._read_loop, daemon=True, name="pool-read")
        for t in (*self._senders, self._reader):
            t.start()

    # --- construction -------------------------------------------------------------------------------
    @classmethod
    def of_processes(cls, factory: Callable[[], object], workers: int,
                     on_result: Callable[[DetectResult], None] | None = None, *,
                     max_batch: int = 4, max_pending: int = 300, max_inflight: int | None = None,
                     max_age_s: float | None = None, start_timeout_s: float = START_TIMEOUT_S) -> DetectorPool:
        """``workers`` processes, each building its detector with ``factory`` (picklable; e.g. a detector
        config's ``build``). ``max_age_s``: a frame queued here longer than this (s) when a worker comes to it is
        skipped rather than detected (live keypoints stay fresh). RuntimeError naming the worker when one cannot build
        its detector."""
        if workers < 1 or max_batch < 1:
            raise ValueError(f"detector pool: workers and max_batch must be >= 1, got {workers}, {max_batch}")
        spawn = functools.partial(_spawn_worker, factory, max_batch)
        started = [spawn(i) for i in range(workers)]
        skeleton = _await_ready(started, start_timeout_s)
        log.info("detector pool: %d worker processes (pids %s), batches of up to %d frames", workers,
                 ", ".join(str(w.process.pid) for w in started), max_batch)
        pool = cls(started, skeleton, on_result, max_pending=max_pending,
                   max_inflight=max_inflight or 2 * max_batch, max_age_s=max_age_s)
        pool._respawn = spawn
        return pool

    @classmethod
    def in_process(cls, detector, on_result: Callable[[DetectResult], None] | None = None, *, max_batch: int = 1,
                   max_pending: int = 600, max_age_s: float | None = None) -> DetectorPool:
        """One worker thread running ``detector`` (already built) in this process."""
        parent, child = multiprocessing.Pipe(duplex=True)
        thread = threading.Thread(target=_thread_main, args=(detector, child, max_batch), daemon=True,
                                  name="detect-0")
        thread.start()
        return cls([_Worker(0, parent, thread=thread)], detector.skeleton.name, on_result,
                   max_pending=max_pending, max_inflight=2 * max_batch, max_age_s=max_age_s)

    # --- routing ------------------------------------------------------------------------------------
    def submit(self, task: FrameTask) -> None:
        """Queue a frame for its camera's worker (the oldest frame of that queue skipped when full)."""
        with self._cond:
            worker = self._worker_for(task.camera)
            if worker is None:
                self.counts.lost[task.camera] += 1
                return
            if len(worker.pending) >= self.max_pending:
                old = worker.pending.popleft()
                self.counts.skipped[old.camera] += 1
            worker.pending.append(replace(task, queued_ns=time.monotonic_ns()))
            self._cond.notify_all()

    def _worker_for(self, camera: str) -> _Worker | None:
        worker = self._route.get(camera)
        if worker is not None and worker.alive:
            return worker
        alive = [w for w in self._workers if w.alive]
        if not alive:
            return None
        worker = min(alive, key=lambda w: (len(w.cameras), w.index))
        worker.cameras.add(camera)
        self._route[camera] = worker
        return worker

    def assignment(self) -> dict[str, int]:
        """{camera: the index of the worker detecting it}."""
        with self._cond:
            return {c: w.index for c, w in self._route.items() if w.alive}

    def alive_workers(self) -> list[int]:
        with self._cond:
            return [w.index for w in self._workers if w.alive]

    @property
    def size(self) -> int:
        """The pool's size: workers it keeps (a dead one is replaced)."""
        return self._size

    def pids(self) -> dict[int, int]:
        """{worker index: its process id} of every worker process started (empty for an in-process pool)."""
        with self._cond:
            return {w.index: w.process.pid for w in self._workers if w.process is not None}

    def queued(self) -> int:
        """Frames queued or with a worker, over the live workers."""
        with self._cond:
            return sum(len(w.pending) + len(w.inflight) for w in self._workers if w.alive)

    def busy(self) -> bool:
        """Whether any frame is queued or with a worker."""
        with self._cond:
            return any(w.pending or w.inflight for w in self._workers if w.alive)

    # --- threads ------------------------------------------------------------------------------------
    def _send_loop(self, worker: _Worker) -> None:
        while True:
            with self._cond:
                while not self._closed and worker.alive and (not worker.pending or len(worker.inflight) >= self.max_inflight):
                    self._cond.wait(0.5)
                if self._closed or not worker.alive:
                    return
                stride = self._stride(worker)
                task = worker.pending.popleft()
                too_old = self.max_age_ns is not None and time.monotonic_ns() - task.queued_ns > self.max_age_ns
                if too_old or task.frame_id % stride:
                    self.counts.skipped[task.camera] += 1  # too old to be live, or thinned out
                    continue
                worker.inflight[(task.camera, task.frame_id)] = task
            try:
                worker.conn.send(task)
            except (OSError, ValueError):  # its pipe closed: the reader sees the death
                return

    def _stride(self, worker: _Worker) -> int:
        """Behind by more than ``THIN_AFTER`` frames per camera, only every 2nd (4th, ... up to ``MAX_STRIDE``-th)
        frame id is detected: the same frame ids on every worker and camera (their frame ids are counted from
        one synchronised start), so the live keypoints of the cameras stay on common frames."""
        if not self.thin:
            return 1
        backlog = len(worker.pending) / max(1, len(worker.cameras))
        stride = 1
        while backlog > THIN_AFTER * stride and stride < MAX_STRIDE:
            stride *= 2
        return stride

    def _read_loop(self) -> None:
        while not self._closed:
            with self._cond:
                live = [w for w in self._workers if w.alive]
            if not live:
                time.sleep(0.1)  # a replacement may be starting
                continue
            waits = {w.conn: w for w in live} | {w.process.sentinel: w for w in live if w.process is not None}
            for ready in wait(list(waits), timeout=0.5):
                worker = waits[ready]
                if ready is worker.conn:
                    self._receive(worker)
                elif worker.alive:
                    self._died(worker)

    def _receive(self, worker: _Worker) -> None:
        try:
            msg = worker.conn.recv()
        except Exception:  # EOF, or a message cut short by a worker killed while sending
            if worker.alive:
                self._died(worker)
            return
        if not isinstance(msg, DetectResult):
            return
        with self._cond:
            worker.inflight.pop((msg.task.camera, msg.task.frame_id), None)
            self._cond.notify_all()
        if self.on_result is None:
            return
        try:
            self.on_result(msg)
        except Exception:  # a publishing failure must not stop the reader
            log.exception("detector pool: handling the result of camera %s frame %d failed", msg.task.camera,
                          msg.task.frame_id)

    def _died(self, worker: _Worker) -> None:
        with self._cond:
            if self._closed:
                worker.alive = False
                return
            worker.alive = False
            for task in worker.inflight.values():
                self.counts.lost[task.camera] += 1
            worker.inflight.clear()
            queued, cameras = list(worker.pending), sorted(worker.cameras)
            worker.pending.clear()
            worker.cameras.clear()
            for cam in cameras:
                self._route.pop(cam, None)
            moved = {cam: self._worker_for(cam) for cam in cameras}
            for task in queued:
                target = moved.get(task.camera)
                if target is None:
                    self.counts.lost[task.camera] += 1
                else:
                    target.pending.append(task)
            self._cond.notify_all()
        if self._respawn is not None and self.respawned < MAX_RESPAWNS:
            threading.Thread(target=self._replace, args=(worker,), daemon=True, name="pool-respawn").start()
        code = worker.process.exitcode if worker.process is not None else None
        where = {cam: (w.index if w is not None else None) for cam, w in moved.items()}
        if any(w is not None for w in moved.values()):
            log.warning("detector %s died (exit code %s); its cameras moved: %s", worker.name, code, where)
        else:
            log.error("detector %s died (exit code %s) and no worker is left for cameras %s", worker.name, code,
                      cameras)

    def _replace(self, dead: _Worker) -> None:
        """Start a worker in place of ``dead`` and hand it cameras from the busiest workers (their tracking
        starts again once); given up, with an error, when it cannot start."""
        time.sleep(RESPAWN_DELAY_S)
        with self._cond:
            if self._closed:
                return
            self.respawned += 1
            index, self._next_index = self._next_index, self._next_index + 1
        try:
            worker = self._respawn(index)
            _await_ready([worker], START_TIMEOUT_S)
        except Exception as exc:  # no replacement: the workers left carry on
            log.error("detector worker %d could not be replaced: %s", dead.index, exc)
            return
        with self._cond:
            if self._closed:
                _stop_all([worker])
                return
            self._workers.append(worker)
            sender = threading.Thread(target=self._send_loop, args=(worker,), daemon=True, name=f"pool-send-{index}")
            self._senders.append(sender)
            moved = self._rebalance(worker)
            self._cond.notify_all()
        sender.start()
        log.warning("detector %s replaces worker %d; cameras moved to it: %s", worker.name, dead.index, moved)

    def _rebalance(self, new: _Worker) -> list[str]:
        """Move cameras from the busiest live workers to ``new`` until counts differ by at most one."""
        moved = []
        while True:
            busiest = max((w for w in self._workers if w.alive and w is not new), key=lambda w: len(w.cameras),
                          default=None)
            if busiest is None or len(busiest.cameras) - len(new.cameras) <= 1:
                return moved
            cam = sorted(busiest.cameras)[-1]
            busiest.cameras.discard(cam)
            new.cameras.add(cam)
            self._route[cam] = new
            keep = [t for t in busiest.pending if t.camera != cam]
            new.pending.extend(t for t in busiest.pending if t.camera == cam)
            busiest.pending.clear()
            busiest.pending.extend(keep)
            moved.append(cam)

    def close(self, timeout_s: float = 5.0) -> None:
        """Stop the workers (frames still queued are left undetected)."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        for t in self._senders:  # one writer per pipe: the sender finishes its frame first
            t.join(timeout_s)
        for w in self._workers:
            try:
                w.conn.send(None)
            except (OSError, ValueError):
                pass
        for w in self._workers:
            if w.process is not None:
                w.process.join(timeout_s)
                if w.process.is_alive():
                    w.process.terminate()
                    w.process.join(timeout_s)
            elif w.thread is not None:
                w.thread.join(timeout_s)
        self._reader.join(timeout_s)
        for w in self._workers:
            w.conn.close()


def _spawn_worker(factory: Callable[[], object], max_batch: int, index: int) -> _Worker:
    ctx = multiprocessing.get_context("spawn")  # never fork a process with bus threads
    parent, child = ctx.Pipe(duplex=True)
    proc = ctx.Process(target=_process_main, args=(factory, child, index, max_batch), daemon=True,
                       name=f"gaitcap-detector-{index}")
    proc.start()
    child.close()
    return _Worker(index, parent, process=proc)


def _await_ready(workers: list[_Worker], timeout_s: float) -> str:
    """Each worker's first message: its skeleton, or why it could not build its detector."""
    skeletons = set()
    end = time.monotonic() + timeout_s
    for w in workers:
        if not w.conn.poll(max(0.0, end - time.monotonic())):
            _stop_all(workers)
            raise RuntimeError(f"detector {w.name} did not start within {timeout_s:g} s")
        try:
            kind, value = w.conn.recv()
        except EOFError:
            _stop_all(workers)
            raise RuntimeError(f"detector {w.name} exited while starting (exit code {w.process.exitcode})") from None
        if kind == "error":
            _stop_all(workers)
            raise RuntimeError(f"detector {w.name} could not build its detector: {value}")
        skeletons.add(value)
    if len(skeletons) != 1:
        _stop_all(workers)
        raise RuntimeError(f"detector pool: workers disagree on the skeleton {sorted(skeletons)}")
    return skeletons.pop()


def _stop_all(workers: list[_Worker]) -> None:
    for w in workers:
        if w.process is not None and w.process.is_alive():
            w.process.terminate()
            w.process.join(5)
