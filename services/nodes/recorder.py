"""Recorder node: writes one MCAP per trial from the bus (frames, keypoints, camera status), and each
keypoint message also as Foxglove image annotations (``WriterSettings.annotations``).

Control through queryables (``<prefix>/recorder/start|stop|status``, see :mod:`gaitcap.services.bus.keys`), so
the caller gets an acknowledgement. Subscriber callbacks only enqueue; one writer thread writes the MCAP.
The queue is bounded (:class:`QueuePolicy`): when the disk is slower than the cameras a subscriber waits
at most ``block_s`` for room, then the message is dropped and counted per camera (``dropped_frames`` in
the trial's summary, its images also in ``dropped_images``), so a slow disk cannot eat the machine's memory. On a write error (disk full, file
size limit) the recording stops cleanly: the ``.part`` file is closed, an ``error`` event is published
and the stop reply carries the error. Events go to ``<prefix>/recorder/events``.

Finished recordings are served on ``<prefix>/recorder/recording/<trial>`` for workers without the shared
store (:mod:`gaitcap.services.bus.recording_transfer`). Recovery on restart: at start the recorder finalises every ``*.mcap.part`` a recorder that died left in
its data folder (:func:`recover_orphans`): the complete chunks become the trial's ``*.mcap`` (its summary
says ``recovered`` and where it was cut; the API's trial guard then marks the trial ``recovered`` and
queues it), the cut original is kept as ``*.mcap.part.cut``.

Every message is parsed into its typed structure (:mod:`gaitcap.services.bus.messages`) and bounded:
a frame id more than ``MAX_TRIAL_FRAMES`` from the trial's first frame, or keypoints for a frame id
more than ``KEYPOINT_SLACK_FRAMES`` outside the recorded frames, are rejected with a log line and
counted (``rejected`` in the summary). The recorder only writes inside its data folder: a start whose
path resolves outside it (``..``, an absolute path elsewhere, a symbolic link out) is refused.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from gaitcap.acquisition.recording.foxglove_messages import image_annotations
from gaitcap.acquisition.recording.writer import TrialWriter, WriterSettings
from gaitcap.services.bus.messages import (
    CameraStatus,
    ImageFrame,
    Keypoints,
    RecorderEvent,
    RecorderReply,
    RecorderStart,
    RecorderStop,
)
from gaitcap.services.bus.recording_transfer import RecordingServer
from gaitcap.services.bus.session import BusConfig, declare_alive

log = logging.getLogger(__name__)

_STOP = object()


@dataclass(frozen=True)
class QueuePolicy:
    """The writer queue's bound: ``max_items`` messages (frames, keypoints, status); a subscriber waits
    at most ``block_s`` seconds for room, then drops the message and counts it."""

    max_items: int = 1000
    block_s: float = 0.25

    def __post_init__(self) -> None:
        if self.max_items < 10:
            raise ValueError(f"max_items: need >= 10 queued messages, got {self.max_items}")
        if not 0 <= self.block_s <= 5:
            raise ValueError(f"block_s: must be in [0, 5] s, got {self.block_s}")


def recover_orphans(root: Path) -> list[dict[str, Any]]:
    """Finalise every ``*.mcap.part`` under ``root`` (left by a recorder that died) into ``*.mcap``
    (complete chunks kept, the cut original kept as ``*.mcap.part.cut``); one report per file."""
    from gaitcap.acquisition.recording.recovery import finalise_cut

    return [finalise_cut(part) for part in sorted(Path(root).rglob("*.mcap.part"))]


MAX_TRIAL_FRAMES = 10_000_000  # frame ids of one trial span at most this many frames (3.8 days at 30/s)
RESTART_BACK_FRAMES = 60  # a frame id this far below the camera's highest so far: its counter started again
KEYPOINT_SLACK_FRAMES = 600  # keypoints may name frames this far outside the recorded frames' range
_LOGGED_REJECTIONS = 20  # per trial; the rest are only counted


def confined_path(data_root: Path, path: str) -> Path:
    """``path`` (relative to ``data_root`` or absolute) resolved; ValueError unless it is an ``.mcap``
    inside ``data_root`` (after resolving ``..`` and symbolic links)."""
    root = Path(data_root).expanduser().resolve()
    target = (root / Path(path).expanduser()).resolve()
    if not target.is_relative_to(root) or target == root:
        raise ValueError(f"path {path!r} is outside the recorder's data folder {root}")
    if target.suffix != ".mcap":
        raise ValueError(f"path {path!r} must end with .mcap")
    return target


@dataclass
class CameraTally:
    """What arrived from one camera during a trial."""

    frames: int = 0
    keypoints: int = 0
    frame_ids: list[int] = field(default_factory=list)
    last_timestamp_ns: int | None = None
    latencies_ns: list[int] = field(default_factory=list)
    last_status: dict[str, Any] | None = None

    def summary(self, last_frame_id_all: int | None) -> dict[str, Any]:
        """Counts, gaps and restarts; ``last_frame_id_all``: the last frame id of any camera (judges a camera
        that stopped early; not applied to a camera whose counter restarted: its ids are another count)."""
        segments = [np.unique(seg) for seg in _counter_segments(self.frame_ids)]  # each count's ids, sorted
        gaps = [g for seg in segments for g in _gap_ranges(seg)]
        ids = np.unique(np.asarray(self.frame_ids, dtype=np.int64))
        missing_inside = int(sum(b - a + 1 for a, b in gaps))
        missing_end = 0
        last = int(segments[-1][-1]) if segments else None
        if last is not None and len(segments) == 1 and last_frame_id_all is not None and last_frame_id_all > last:
            missing_end = int(last_frame_id_all - last)
            gaps.append([last + 1, int(last_frame_id_all)])
        return {
            "frames": self.frames,
            "keypoints": self.keypoints,
            "first_frame_id": int(ids[0]) if ids.size else None,
            "last_frame_id": int(ids[-1]) if ids.size else None,
            "duplicates": int(len(self.frame_ids) - sum(seg.size for seg in segments)),
            "missing_frames": missing_inside + missing_end,
            "stopped_early": missing_end > 0,
            "restarts": len(segments) - 1 if segments else 0,
            "gaps": gaps,
            "health": (self.last_status or {}).get("health"),
        }


def _counter_segments(frame_ids: list[int]) -> list[np.ndarray]:
    """Frame ids in arrival order, cut where the camera's counter started again (an id more than
    RESTART_BACK_FRAMES below the highest so far: a restarted camera, not frames reordered on the bus)."""
    ids = np.asarray(frame_ids, dtype=np.int64)
    if ids.size == 0:
        return []
    cuts, high = [0], ids[0]
    for i in range(1, ids.size):
        if ids[i] < high - RESTART_BACK_FRAMES:
            cuts.append(i)
            high = ids[i]
        high = max(high, ids[i])
    cuts.append(ids.size)
    return [ids[a:b] for a, b in zip(cuts[:-1], cuts[1:], strict=True)]


def _gap_ranges(ids: np.ndarray) -> list[list[int]]:
    if ids.size < 2:
        return []
    jumps = np.flatnonzero(np.diff(ids) > 1)
    return [[int(ids[i]) + 1, int(ids[i + 1]) - 1] for i in jumps]


class Recording:
    """One trial being written (lives on the writer thread)."""

    def __init__(self, trial_id: str, path: Path, writer: TrialWriter, cameras: list[str] | None) -> None:
        self.trial_id, self.path, self.writer = trial_id, path, writer
        self.expected = list(cameras or [])
        self.tallies: dict[str, CameraTally] = {c: CameraTally() for c in self.expected}
        self.error: str | None = None
        self.started_wall = time.time()
        self.started_cpu = time.process_time()
        self.first_write: tuple[float, float] | None = None  # (wall s, process cpu s) at the first frame
        self.last_write: tuple[float, float] | None = None
        self.dropped: dict[str, int] = {}  # camera -> messages dropped because the queue stayed full
        self.dropped_images: dict[str, int] = {}  # camera -> of those, its images
        self.frame_range: tuple[int, int] | None = None  # (first, last) frame id recorded, all cameras
        self.early_anchor: int | None = None  # the first keypoints' frame id, while no frame is recorded yet
        self.rejected = 0

    def reject(self, message: str) -> None:
        self.rejected += 1
        if self.rejected <= _LOGGED_REJECTIONS:
            log.warning("trial %s: rejected %s", self.trial_id, message)

    def accept_frame(self, camera: str, frame_id: int) -> bool:
        """Keep the frame unless its id is beyond the trial's range (first frame + MAX_TRIAL_FRAMES)."""
        if self.frame_range is None:
            self.frame_range = (frame_id, frame_id)
        lo, hi = self.frame_range
        if not lo - MAX_TRIAL_FRAMES <= frame_id <= lo + MAX_TRIAL_FRAMES:
            self.reject(f"a frame of camera {camera} with frame id {frame_id}, trial started at {lo}")
            return False
        self.frame_range = (min(lo, frame_id), max(hi, frame_id))
        return True

    def accept_keypoints(self, camera: str, frame_id: int) -> bool:
        """Keep keypoints only for frame ids near the frames recorded so far. Keypoints may overtake their
        image on the bus (the detector answers faster than the recorder takes the frame): before any frame
        is recorded they are kept within the same slack of the first keypoints' frame id."""
        if self.frame_range is None and self.early_anchor is None:
            self.early_anchor = frame_id
        lo, hi = self.frame_range or (self.early_anchor, self.early_anchor)
        if not lo - KEYPOINT_SLACK_FRAMES <= frame_id <= hi + KEYPOINT_SLACK_FRAMES:
            self.reject(f"keypoints of camera {camera} for frame id {frame_id}, outside the recorded frames "
                        f"{self.frame_range}")
            return False
        return True

    def tally(self, camera: str) -> CameraTally:
        return self.tallies.setdefault(camera, CameraTally())

    def write(self, kind: str, camera: str, payload: bytes, att: bytes | None, recv_ns: int) -> None:
        """Write one bus message of ``kind`` (image | keypoints | status) from ``camera``, as received at
        ``recv_ns`` (ns); ValueError for a message that contradicts its key or cannot be parsed."""
        writer = {"image": self.write_image, "keypoints": self.write_keypoints, "status": self.write_status}[kind]
        writer(camera, payload, att, recv_ns)

    def write_image(self, camera: str, payload: bytes, att: bytes | None, recv_ns: int) -> None:
        frame = ImageFrame.from_bytes(payload, att, camera=camera)
        fid, ts = frame.frame_id, frame.timestamp_ns
        if not self.accept_frame(camera, fid):
            return
        tally = self.tally(camera)
        self.writer.add_frame(camera, payload, timestamp_ns=ts, frame_id=fid, receive_ns=recv_ns)
        tally.frames += 1
        tally.frame_ids.append(fid)
        self.last_write = (time.time(), time.process_time())
        self.first_write = self.first_write or self.last_write
        tally.last_timestamp_ns = ts
        tally.latencies_ns.append(recv_ns - frame.meta.sent_ns)

    def write_keypoints(self, camera: str, payload: bytes, att: bytes | None, recv_ns: int) -> None:
        del att, recv_ns  # keypoints carry their own frame id and timestamp
        kp = Keypoints.from_bytes(payload)
        if kp.camera != camera:
            raise ValueError(f"keypoints on camera {camera}'s key name camera {kp.camera}")
        if not self.accept_keypoints(camera, kp.frame_id):
            return
        self.writer.add_keypoints(camera, payload, timestamp_ns=kp.timestamp_ns, frame_id=kp.frame_id)
        if self.writer.settings.annotations:  # the overlay Foxglove draws on this frame's image
            self.writer.add_annotations(camera, image_annotations(kp), timestamp_ns=kp.timestamp_ns,
                                        frame_id=kp.frame_id)
        self.tally(camera).keypoints += 1

    def write_status(self, camera: str, payload: bytes, att: bytes | None, recv_ns: int) -> None:
        del att
        status = CameraStatus.from_bytes(payload)
        if status.camera != camera:
            raise ValueError(f"status on camera {camera}'s key names camera {status.camera}")
        self.tally(camera).last_status = status.to_dict()
        self.writer.add_status(camera, payload, time_ns=recv_ns)

    def summary(self) -> dict[str, Any]:
        last = max((max(t.frame_ids) for t in self.tallies.values() if t.frame_ids), default=None)
        lat = np.concatenate([np.asarray(t.latencies_ns, dtype=np.float64) for t in self.tallies.values()]
                             + [np.zeros(0)])
        elapsed = max(time.time() - self.started_wall, 1e-9)
        cpu = time.process_time() - self.started_cpu
        active_s = active_cpu = 0.0
        if self.first_write and self.last_write:
            active_s = self.last_write[0] - self.first_write[0]
            active_cpu = self.last_write[1] - self.first_write[1]
        cams = {c: t.summary(last) for c, t in sorted(self.tallies.items())}
        return {
            "trial_id": self.trial_id,
            "cameras": cams,
            "frames": int(sum(c["frames"] for c in cams.values())),
            "keypoints": int(sum(c["keypoints"] for c in cams.values())),
            "missing_frames": int(sum(c["missing_frames"] for c in cams.values())),
            "cameras_without_frames": sorted(c for c, t in cams.items() if t["frames"] == 0),
            "cameras_stopped_early": sorted(c for c, t in cams.items() if t["stopped_early"]),
            "latency_ms_p50": float(np.percentile(lat, 50) / 1e6) if lat.size else None,
            "latency_ms_p99": float(np.percentile(lat, 99) / 1e6) if lat.size else None,
            "duration_s": elapsed,
            "cpu_s": cpu,
            "cpu_percent": 100.0 * cpu / elapsed,
            "active_s": active_s,
            "active_cpu_percent": 100.0 * active_cpu / active_s if active_s > 0 else None,
            "rejected": self.rejected,
            "dropped_frames": dict(sorted(self.dropped.items())),
            "dropped_images": dict(sorted(self.dropped_images.items())),
            "error": self.error,
        }


class _NoRequest:
    """The status query carries no payload."""

    @classmethod
    def from_bytes(cls, data: bytes) -> None:
        if bytes(data) not in (b"", b"{}"):
            raise ValueError("recorder status: the query takes no payload")


class RecorderNode:
    """Serves start/stop/status queries and records the bus into MCAP files inside ``data_root``."""

    def __init__(self, session, bus: BusConfig, node: str = "recorder", *, data_root: Path,
                 settings: WriterSettings = WriterSettings(), policy: QueuePolicy = QueuePolicy()) -> None:
        self.session, self.bus, self.node, self.settings, self.policy = session, bus, node, settings, policy
        self.data_root = Path(data_root).expanduser().resolve()
        keys = bus.keys
        self.recovered = recover_orphans(self.data_root) if self.data_root.is_dir() else []
        self._queue: queue.Queue = queue.Queue(maxsize=policy.max_items)
        self._lock = threading.Lock()
        self._lock_drops = threading.Lock()
        self._current: Recording | None = None
        self._accepting = False
        self._events = session.declare_publisher(keys.recorder_events)
        self._subs = [
            session.declare_subscriber(keys.image(), self._on_image),
            session.declare_subscriber(keys.keypoints(), self._on_keypoints),
            session.declare_subscriber(keys.status(), self._on_status),
        ]
        self._queryables = [
            session.declare_queryable(keys.recorder_start, self._on_start),
            session.declare_queryable(keys.recorder_stop, self._on_stop),
            session.declare_queryable(keys.recorder_status, self._on_status_query),
        ]
        # finished recordings, chunk by chunk, for workers without the shared store
        self._serving = RecordingServer(session, keys, resolve=lambda path: confined_path(self.data_root, path))
        self._writer_thread = threading.Thread(target=self._write_loop, name="mcap-writer", daemon=True)
        self._writer_thread.start()
        self._token = declare_alive(session, bus, node)

    # -- bus callbacks: enqueue only ----------------------------------------------------------------
    def _enqueue(self, item: tuple) -> None:
        """Queue for the writer; wait at most ``policy.block_s`` for room, then drop and count."""
        try:
            self._queue.put(item, timeout=self.policy.block_s)
        except queue.Full:
            rec = self._current
            if rec is not None:
                camera = self.bus.keys.camera_of(item[1])
                with self._lock_drops:
                    rec.dropped[camera] = rec.dropped.get(camera, 0) + 1
                    if item[0] == "image":
                        rec.dropped_images[camera] = rec.dropped_images.get(camera, 0) + 1

    def _on_image(self, sample) -> None:
        if self._accepting:
            att = sample.attachment.to_bytes() if sample.attachment is not None else None
            self._enqueue(("image", str(sample.key_expr), sample.payload.to_bytes(), att, time.time_ns()))

    def _on_keypoints(self, sample) -> None:
        if self._accepting:
            self._enqueue(("keypoints", str(sample.key_expr), sample.payload.to_bytes(), b"", time.time_ns()))

    def _on_status(self, sample) -> None:
        if self._accepting:
            self._enqueue(("status", str(sample.key_expr), sample.payload.to_bytes(), b"", time.time_ns()))

    # -- writer thread ----------------------------------------------------------------------------
    def _write_loop(self) -> None:
        while True:
            item = self._queue.get()
            if isinstance(item, tuple) and item[0] == "control":
                item[1]()
                continue
            rec = self._current
            if rec is None or rec.error is not None:
                continue
            try:
                self._write(rec, *item)
            except OSError as exc:
                self._fail(rec, f"write failed ({exc.strerror or exc}); recording stopped, "
                                f"partial file {rec.writer.part_path}")
            except ValueError as exc:
                rec.reject(f"a bad message on {item[1]}: {exc}")
            except Exception as exc:  # a bug must not end the writer thread: Stop and later messages still run
                if rec.rejected < _LOGGED_REJECTIONS:  # the traceback, as far as rejections are logged
                    log.exception("trial %s: a message on %s could not be written", rec.trial_id, item[1])
                rec.reject(f"a message on {item[1]} could not be written ({type(exc).__name__}: {exc})")

    def _write(self, rec: Recording, kind: str, key: str, payload: bytes, att: bytes | None, recv_ns: int) -> None:
        rec.write(kind, self.bus.keys.camera_of(key), payload, att, recv_ns)

    def _fail(self, rec: Recording, message: str) -> None:
        log.error("trial %s: %s", rec.trial_id, message)
        rec.error = message
        self._accepting = False
        rec.writer.abort()
        self._publish_event("error", rec, summary=rec.summary())

    def _on_writer(self, fn) -> Any:
        """Run ``fn`` on the writer thread after everything queued so far; return its result."""
        done = threading.Event()
        box: dict[str, Any] = {}

        def run() -> None:
            try:
                box["value"] = fn()
            except Exception as exc:  # handed back to the caller
                box["error"] = exc
            finally:
                done.set()

        self._queue.put(("control", run))
        done.wait()
        if "error" in box:
            raise box["error"]
        return box.get("value")

    def _publish_event(self, event: str, rec: Recording, summary: dict | None = None) -> None:
        self._events.put(RecorderEvent(event=event, trial_id=rec.trial_id, path=str(rec.path), error=rec.error,
                                       time_ns=time.time_ns(), summary=summary).to_bytes())

    # -- control ----------------------------------------------------------------------------------
    def start(self, request: RecorderStart) -> RecorderReply:
        trial_id = request.trial_id
        try:
            path = confined_path(self.data_root, request.path)
        except ValueError as exc:
            raise ValueError(f"start {trial_id}: {exc}") from None
        with self._lock:
            if self._current is not None:
                raise ValueError(f"start {trial_id}: already recording trial {self._current.trial_id}")
            writer = TrialWriter(path, self.settings)
            rec = Recording(trial_id, path, writer, request.cameras)
            meta = dict(request.metadata)
            meta.setdefault("trial_id", trial_id)
            try:
                writer.start(metadata=meta, calibration_toml=request.calibration_toml, time_ns=time.time_ns())
            except OSError as exc:
                writer.abort()
                raise ValueError(f"start {trial_id}: cannot write {path}: {exc}") from None
            self._on_writer(lambda: setattr(self, "_current", rec))
            self._accepting = True
        self._publish_event("started", rec)
        log.info("recording trial %s into %s", trial_id, path)
        return RecorderReply(ok=True, trial_id=trial_id, path=str(path))

    def stop(self, request: RecorderStop) -> RecorderReply:
        trial_id = request.trial_id
        with self._lock:
            rec = self._current
            if rec is None or rec.trial_id != trial_id:
                now = rec.trial_id if rec else None
                raise ValueError(f"stop {trial_id}: not recording it (recording: {now})")
            self._accepting = False
            path = self._on_writer(lambda: self._finish(rec))
            self._current = None
        summary = rec.summary()
        self._publish_event("stopped" if rec.error is None else "error", rec, summary=summary)
        return RecorderReply(ok=rec.error is None, trial_id=trial_id, path=str(path), error=rec.error,
                             summary=summary)

    def _finish(self, rec: Recording) -> Path:
        if rec.error is not None:
            return rec.writer.part_path
        try:
            return rec.writer.finish(rec.summary())
        except OSError as exc:
            self._fail(rec, f"finishing failed ({exc.strerror or exc}); partial file {rec.writer.part_path}")
            return rec.writer.part_path

    def status(self) -> RecorderReply:
        rec = self._current
        return RecorderReply(ok=True, recording=rec is not None, trial_id=rec.trial_id if rec else None,
                             path=str(rec.path) if rec else None, error=rec.error if rec else None,
                             queued=self._queue.qsize())

    def _serve(self, query, message_type, handler) -> None:
        key, unexpected = str(query.key_expr), None
        try:
            request = message_type.from_bytes(query.payload.to_bytes() if query.payload else b"{}")
            reply = handler(request)
        except ValueError as exc:
            reply = RecorderReply(ok=False, error=str(exc))
        except Exception as exc:
            unexpected = exc
            reply = RecorderReply(ok=False, error=f"{type(exc).__name__}: {exc}")
        query.reply(query.key_expr, reply.to_bytes())
        del query  # the reply goes out when the query is dropped; log only after that
        if unexpected is not None:
            log.error("recorder request on %s failed", key, exc_info=unexpected)
        elif not reply.ok:
            log.warning("recorder request on %s refused: %s", key, reply.error)

    def _on_start(self, query) -> None:
        # Served off Zenoh's callback thread: a stop waits for the writer to drain its queue.
        threading.Thread(target=self._serve, args=(query, RecorderStart, self.start), daemon=True).start()

    def _on_stop(self, query) -> None:
        threading.Thread(target=self._serve, args=(query, RecorderStop, self.stop), daemon=True).start()

    def _on_status_query(self, query) -> None:
        self._serve(query, _NoRequest, lambda _req: self.status())

    def close(self) -> None:
        """Finish a recording in progress (as a clean stop) and leave the bus."""
        rec = self._current
        if rec is not None:
            self.stop(RecorderStop(rec.trial_id))
        self._token.undeclare()
        self._serving.close()
        for s in self._subs + self._queryables:
            s.undeclare()
