"""Recorder node: writes one MCAP per trial from the bus (frames, keypoints, camera status), and each
keypoint message also as Foxglove image annotations (``WriterSettings.annotations``).

Control through queryables (``<prefix>/recorder/start|stop|status``, see :mod:`gaitcap.services.bus.keys`), so
the caller gets an acknowledgement. Subscriber callbacks only enqueue (a deep queue, so no publisher is
ever stalled by disk latency); one writer thread writes the MCAP. On a write error (disk full, file
size limit) the recording stops cleanly: the ``.part`` file is closed, an ``error`` event is published
and the stop reply carries the error. Events go to ``<prefix>/recorder/events``.
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
from gaitcap.services.bus.keys import dumps, loads
from gaitcap.services.bus.session import BusConfig, declare_alive

log = logging.getLogger(__name__)

_STOP = object()


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
        ids = np.unique(np.asarray(self.frame_ids, dtype=np.int64))
        gaps = _gap_ranges(ids)
        missing_inside = int(sum(b - a + 1 for a, b in gaps))
        missing_end = 0
        if ids.size and last_frame_id_all is not None and last_frame_id_all > ids[-1]:
            missing_end = int(last_frame_id_all - ids[-1])
            gaps.append([int(ids[-1]) + 1, int(last_frame_id_all)])
        return {
            "frames": self.frames,
            "keypoints": self.keypoints,
            "first_frame_id": int(ids[0]) if ids.size else None,
            "last_frame_id": int(ids[-1]) if ids.size else None,
            "duplicates": int(len(self.frame_ids) - ids.size),
            "missing_frames": missing_inside + missing_end,
            "stopped_early": missing_end > 0,
            "gaps": gaps,
            "health": (self.last_status or {}).get("health"),
        }


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

    def tally(self, camera: str) -> CameraTally:
        return self.tallies.setdefault(camera, CameraTally())

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
            "error": self.error,
        }


class RecorderNode:
    """Serves start/stop/status queries and records the bus into MCAP files."""

    def __init__(self, session, bus: BusConfig, node: str = "recorder", *,
                 settings: WriterSettings = WriterSettings()) -> None:
        self.session, self.bus, self.node, self.settings = session, bus, node, settings
        keys = bus.keys
        self._queue: queue.Queue = queue.Queue()
        self._lock = threading.Lock()
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
        self._writer_thread = threading.Thread(target=self._write_loop, name="mcap-writer", daemon=True)
        self._writer_thread.start()
        self._token = declare_alive(session, bus, node)

    # -- bus callbacks: enqueue only ----------------------------------------------------------------
    def _on_image(self, sample) -> None:
        if self._accepting:
            att = sample.attachment.to_bytes() if sample.attachment is not None else b"{}"
            self._queue.put(("image", str(sample.key_expr), sample.payload.to_bytes(), att, time.time_ns()))

    def _on_keypoints(self, sample) -> None:
        if self._accepting:
            self._queue.put(("keypoints", str(sample.key_expr), sample.payload.to_bytes(), b"", time.time_ns()))

    def _on_status(self, sample) -> None:
        if self._accepting:
            self._queue.put(("status", str(sample.key_expr), sample.payload.to_bytes(), b"", time.time_ns()))

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
                log.warning("dropping a bad message: %s", exc)

    def _write(self, rec: Recording, kind: str, key: str, payload: bytes, att: bytes, recv_ns: int) -> None:
        camera = self.bus.keys.camera_of(key)
        tally = rec.tally(camera)
        if kind == "image":
            meta = loads(att, what=f"frame attachment of camera {camera}")
            fid, ts = int(meta["frame_id"]), int(meta["timestamp_ns"])
            rec.writer.add_frame(camera, payload, timestamp_ns=ts, frame_id=fid, receive_ns=recv_ns)
            tally.frames += 1
            tally.frame_ids.append(fid)
            rec.last_write = (time.time(), time.process_time())
            rec.first_write = rec.first_write or rec.last_write
            tally.last_timestamp_ns = ts
            if "sent_ns" in meta:
                tally.latencies_ns.append(recv_ns - int(meta["sent_ns"]))
        elif kind == "keypoints":
            msg = loads(payload, what=f"keypoints of camera {camera}")
            ts, fid = int(msg["timestamp_ns"]), int(msg["frame_id"])
            rec.writer.add_keypoints(camera, payload, timestamp_ns=ts, frame_id=fid)
            if self.settings.annotations:  # the overlay Foxglove draws on this frame's image
                rec.writer.add_annotations(camera, image_annotations(msg), timestamp_ns=ts, frame_id=fid)
            tally.keypoints += 1
        else:
            tally.last_status = loads(payload, what=f"status of camera {camera}")
            rec.writer.add_status(camera, payload, time_ns=recv_ns)

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

    def _publish_event(self, event: str, rec: Recording, **extra: Any) -> None:
        self._events.put(dumps({"event": event, "trial_id": rec.trial_id, "path": str(rec.path),
                                "error": rec.error, "time_ns": time.time_ns(), **extra}))

    # -- control ----------------------------------------------------------------------------------
    def start(self, request: dict[str, Any]) -> dict[str, Any]:
        trial_id = str(request.get("trial_id") or "")
        if not trial_id:
            raise ValueError("start: missing trial_id")
        if not request.get("path"):
            raise ValueError(f"start {trial_id}: missing path")
        with self._lock:
            if self._current is not None:
                raise ValueError(f"start {trial_id}: already recording trial {self._current.trial_id}")
            path = Path(request["path"]).expanduser().resolve()
            writer = TrialWriter(path, self.settings)
            rec = Recording(trial_id, path, writer, request.get("cameras"))
            meta = dict(request.get("metadata") or {})
            meta.setdefault("trial_id", trial_id)
            try:
                writer.start(metadata=meta, calibration_toml=request.get("calibration_toml"),
                             time_ns=time.time_ns())
            except OSError as exc:
                writer.abort()
                raise ValueError(f"start {trial_id}: cannot write {path}: {exc}") from None
            self._on_writer(lambda: setattr(self, "_current", rec))
            self._accepting = True
        self._publish_event("started", rec)
        log.info("recording trial %s into %s", trial_id, path)
        return {"ok": True, "trial_id": trial_id, "path": str(path), "error": None}

    def stop(self, request: dict[str, Any]) -> dict[str, Any]:
        trial_id = str(request.get("trial_id") or "")
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
        return {"ok": rec.error is None, "trial_id": trial_id, "path": str(path), "error": rec.error,
                "summary": summary}

    def _finish(self, rec: Recording) -> Path:
        if rec.error is not None:
            return rec.writer.part_path
        try:
            return rec.writer.finish(rec.summary())
        except OSError as exc:
            self._fail(rec, f"finishing failed ({exc.strerror or exc}); partial file {rec.writer.part_path}")
            return rec.writer.part_path

    def status(self) -> dict[str, Any]:
        rec = self._current
        return {"ok": True, "recording": rec is not None, "trial_id": rec.trial_id if rec else None,
                "path": str(rec.path) if rec else None, "error": rec.error if rec else None,
                "queued": self._queue.qsize()}

    def _serve(self, query, handler) -> None:
        try:
            request = loads(query.payload.to_bytes(), what=str(query.key_expr)) if query.payload else {}
            reply = handler(request)
        except ValueError as exc:
            reply = {"ok": False, "error": str(exc)}
        except Exception as exc:
            log.exception("recorder request failed")
            reply = {"ok": False, "error": f"{type(exc).__name__}: {exc}"}
        query.reply(query.key_expr, dumps(reply))

    def _on_start(self, query) -> None:
        # Served off Zenoh's callback thread: a stop waits for the writer to drain its queue.
        threading.Thread(target=self._serve, args=(query, self.start), daemon=True).start()

    def _on_stop(self, query) -> None:
        threading.Thread(target=self._serve, args=(query, self.stop), daemon=True).start()

    def _on_status_query(self, query) -> None:
        self._serve(query, lambda _req: self.status())

    def close(self) -> None:
        """Finish a recording in progress (as a clean stop) and leave the bus."""
        rec = self._current
        if rec is not None:
            self.stop({"trial_id": rec.trial_id})
        self._token.undeclare()
        for s in self._subs + self._queryables:
            s.undeclare()
