"""Small clients of the bus for other services (the web service, the CLI, tests).

    session = open_session(bus)                       # gaitcap.services.bus.session
    rec = RecorderClient(session, bus.keys)
    rec.start(trial_id="t1", path="/data/t1.mcap", metadata={...}, calibration_toml=toml_text)
    summary = rec.stop("t1")                          # frames / gaps per camera, path

    status = CameraStatusBoard(session, bus.keys)     # latest status per camera: status.snapshot()
    preview = PreviewFrames(session, bus.keys)        # latest JPEG per camera: preview.latest()
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from gaitcap.acquisition.encoding import parse_image_message
from gaitcap.services.bus.keys import Keys, dumps, loads


class RecorderError(ValueError):
    """The recorder refused a request or did not answer."""


class RecorderClient:
    """Start / stop trial recordings through the recorder node's queryables (acknowledged)."""

    def __init__(self, session, keys: Keys, *, timeout_s: float = 10.0) -> None:
        self.session = session
        self.keys = keys
        self.timeout_s = timeout_s

    def _query(self, key: str, payload: dict[str, Any] | None) -> dict[str, Any]:
        kwargs = {"timeout": self.timeout_s}
        if payload is not None:
            kwargs["payload"] = dumps(payload)
        for reply in self.session.get(key, **kwargs):
            if reply.ok is not None:
                answer = loads(reply.ok.payload.to_bytes(), what=f"reply of {key}")
                if not answer.get("ok", False):
                    raise RecorderError(f"recorder refused ({key}): {answer.get('error')}")
                return answer
            raise RecorderError(f"recorder error ({key}): {reply.err.payload.to_bytes().decode(errors='replace')}")
        raise RecorderError(f"no recorder answered on {key} within {self.timeout_s} s (is the recorder node running?)")

    def start(self, *, trial_id: str, path: str, metadata: dict[str, Any] | None = None,
              calibration_toml: str | None = None, cameras: list[str] | None = None) -> dict[str, Any]:
        """Start recording ``trial_id`` into ``path`` (on the recorder's host); returns the reply."""
        return self._query(self.keys.recorder_start, {
            "trial_id": trial_id, "path": str(path), "metadata": metadata or {},
            "calibration_toml": calibration_toml, "cameras": cameras,
        })

    def stop(self, trial_id: str) -> dict[str, Any]:
        """Stop recording; returns the reply with ``summary`` (frames, gaps per camera) and ``path``."""
        return self._query(self.keys.recorder_stop, {"trial_id": trial_id})

    def status(self) -> dict[str, Any]:
        return self._query(self.keys.recorder_status, None)


class _Latest:
    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._items: dict[str, Any] = {}

    def set(self, name: str, item: Any) -> None:
        with self._lock:
            self._items[name] = item

    def snapshot(self) -> dict[str, Any]:
        with self._lock:
            return dict(self._items)


class CameraStatusBoard:
    """Keeps the latest status message of every camera (``snapshot()`` -> {camera: status dict})."""

    def __init__(self, session, keys: Keys, on_status: Callable[[dict], None] | None = None) -> None:
        self._latest = _Latest()
        self._on_status = on_status
        self._sub = session.declare_subscriber(keys.status(), self._cb)

    def _cb(self, sample) -> None:
        try:
            status = loads(sample.payload.to_bytes(), what=str(sample.key_expr))
        except ValueError:
            return
        self._latest.set(str(status.get("camera")), status)
        if self._on_status is not None:
            self._on_status(status)

    def snapshot(self) -> dict[str, dict]:
        return self._latest.snapshot()

    def close(self) -> None:
        self._sub.undeclare()


@dataclass(frozen=True)
class PreviewFrame:
    camera: str
    frame_id: int
    timestamp_ns: int
    jpeg: bytes
    received_s: float


class PreviewFrames:
    """Keeps only the latest JPEG of every camera (a live preview never queues old frames)."""

    def __init__(self, session, keys: Keys) -> None:
        self._latest = _Latest()
        self._sub = session.declare_subscriber(keys.image(), self._cb)

    def _cb(self, sample) -> None:
        try:
            msg = parse_image_message(sample.payload.to_bytes())
            att = loads(sample.attachment.to_bytes(), what="frame attachment") if sample.attachment else {}
        except ValueError:
            return
        self._latest.set(msg.camera, PreviewFrame(msg.camera, int(att.get("frame_id", -1)), msg.timestamp_ns,
                                                  msg.jpeg, time.time()))

    def latest(self) -> dict[str, PreviewFrame]:
        return self._latest.snapshot()

    def close(self) -> None:
        self._sub.undeclare()


def subscribe_events(session, keys: Keys, on_event: Callable[[dict], None]):
    """Call ``on_event(event)`` for every recorder event (started / stopped / error)."""

    def _cb(sample) -> None:
        try:
            on_event(loads(sample.payload.to_bytes(), what=keys.recorder_events))
        except ValueError:
            return

    return session.declare_subscriber(keys.recorder_events, _cb)
