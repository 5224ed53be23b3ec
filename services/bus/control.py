"""Small clients of the bus for other services (the web service, the CLI, tests).

    session = open_session(bus)                       # gaitcap.services.bus.session
    rec = RecorderClient(session, bus.keys)
    rec.start(trial_id="t1", path="/data/t1.mcap", metadata={...}, calibration_toml=toml_text)
    summary = rec.stop("t1").summary                  # frames / gaps per camera

Every payload is a typed message of :mod:`gaitcap.services.bus.messages`; malformed ones are dropped
with a log line. A message that names the camera or node whose key it comes on (a camera's status, a
detector node's status, a board view) is received through :func:`named_by_key`, which drops one that names
another.

    status = CameraStatusBoard(session, bus.keys)     # latest status per camera: status.snapshot()
    preview = PreviewFrames(session, bus.keys)        # latest JPEG per camera: preview.latest()
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

from gaitcap.services.bus.keys import Keys
from gaitcap.services.bus.messages import (
    CameraStatus,
    ImageFrame,
    RecorderEvent,
    RecorderReply,
    RecorderStart,
    RecorderStop,
)

log = logging.getLogger(__name__)
M = TypeVar("M")


def named_by_key(cls: type[M], on_message: Callable[[M], None], *, field: str,
                 name_of: Callable[[str], str]) -> Callable[[Any], None]:
    """A subscriber callback for messages of type ``cls`` whose ``field`` names the camera or node whose key
    they come on (``name_of(key)``, e.g. :meth:`Keys.node_of <gaitcap.services.bus.keys.Keys.node_of>`):
    each sample's payload parsed (``cls.from_bytes``) and passed to ``on_message``; a malformed one, or one
    naming another camera or node than its key's, dropped with a warning saying why."""

    def _cb(sample) -> None:
        key = str(sample.key_expr)
        try:
            message = cls.from_bytes(sample.payload.to_bytes())
            named, on_key = getattr(message, field), name_of(key)
            if named != on_key:
                raise ValueError(f"{cls.what} of {field} {named} on {key} (the key of {field} {on_key})")
        except ValueError as exc:
            log.warning("dropping a %s: %s", cls.what, exc)
            return
        on_message(message)

    return _cb


class RecorderError(ValueError):
    """The recorder refused a request or did not answer."""


class RecorderClient:
    """Start / stop trial recordings through the recorder node's queryables (acknowledged)."""

    def __init__(self, session, keys: Keys, *, timeout_s: float = 10.0) -> None:
        self.session = session
        self.keys = keys
        self.timeout_s = timeout_s

    def _query(self, key: str, payload: RecorderStart | RecorderStop | None) -> RecorderReply:
        kwargs = {"timeout": self.timeout_s}
        if payload is not None:
            kwargs["payload"] = payload.to_bytes()
        for reply in self.session.get(key, **kwargs):
            if reply.ok is not None:
                try:
                    answer = RecorderReply.from_bytes(reply.ok.payload.to_bytes())
                except ValueError as exc:
                    raise RecorderError(f"recorder reply on {key}: {exc}") from None
                if not answer.ok:
                    raise RecorderError(f"recorder refused ({key}): {answer.error}")
                return answer
            raise RecorderError(f"recorder error ({key}): {reply.err.payload.to_bytes().decode(errors='replace')}")
        raise RecorderError(f"no recorder answered on {key} within {self.timeout_s} s (is the recorder node running?)")

    def start(self, *, trial_id: str, path: str, metadata: dict[str, Any] | None = None,
              calibration_toml: str | None = None, cameras: list[str] | None = None) -> RecorderReply:
        """Start recording ``trial_id`` into ``path`` (inside the recorder's data folder); the reply."""
        try:
            request = RecorderStart(trial_id=trial_id, path=str(path), metadata=metadata or {},
                                    calibration_toml=calibration_toml, cameras=cameras)
        except ValueError as exc:
            raise RecorderError(str(exc)) from None
        return self._query(self.keys.recorder_start, request)

    def stop(self, trial_id: str) -> RecorderReply:
        """Stop recording; the reply has ``summary`` (frames, gaps per camera) and ``path``."""
        return self._query(self.keys.recorder_stop, RecorderStop(trial_id))

    def status(self) -> RecorderReply:
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
        self._sub = session.declare_subscriber(
            keys.status(), named_by_key(CameraStatus, self._keep, field="camera", name_of=keys.camera_of))

    def _keep(self, parsed: CameraStatus) -> None:
        status = parsed.to_dict()
        self._latest.set(parsed.camera, status)
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
        self._keys = keys
        self._sub = session.declare_subscriber(keys.image(), self._cb)

    def _cb(self, sample) -> None:
        try:
            att = sample.attachment.to_bytes() if sample.attachment is not None else None
            frame = ImageFrame.from_bytes(sample.payload.to_bytes(), att,
                                          camera=self._keys.camera_of(str(sample.key_expr)))
        except ValueError as exc:
            log.debug("dropping a preview frame: %s", exc)
            return
        self._latest.set(frame.camera, PreviewFrame(frame.camera, frame.frame_id, frame.timestamp_ns, frame.jpeg,
                                                    time.time()))

    def latest(self) -> dict[str, PreviewFrame]:
        return self._latest.snapshot()

    def close(self) -> None:
        self._sub.undeclare()


def subscribe_events(session, keys: Keys, on_event: Callable[[RecorderEvent], None]):
    """Call ``on_event(event)`` for every recorder event (started / stopped / error)."""

    def _cb(sample) -> None:
        try:
            event = RecorderEvent.from_bytes(sample.payload.to_bytes())
        except ValueError as exc:
            log.warning("dropping a recorder event: %s", exc)
            return
        on_event(event)

    return session.declare_subscriber(keys.recorder_events, _cb)
