"""Replay a trial MCAP on the bus: frames, keypoints and camera status, as the live nodes publish them.

Messages go out in log-time order (camera time), paced at ``rate`` x real time (``None``: as fast as
the bus takes them). Frames keep their frame id (in the :class:`~gaitcap.services.bus.messages.FrameMeta`
attachment, marked ``replay``) and camera timestamp (in the recorded protobuf), so the
recorder, the worker and the web page cannot tell a replay from a live trial. Works on files cut short
by a crash too (they are scanned).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from gaitcap.acquisition.recording import layout
from gaitcap.acquisition.recording.reader import iter_messages, resolve_recording
from gaitcap.services.bus.keys import Keys
from gaitcap.services.bus.messages import FrameMeta

log = logging.getLogger(__name__)


@dataclass
class ReplayStats:
    frames: int = 0
    keypoints: int = 0
    status: int = 0
    duration_s: float = 0.0
    per_camera: dict[str, int] = field(default_factory=dict)


def _wanted(topic: str, with_keypoints: bool) -> bool:
    return layout.is_image_topic(topic) or layout.is_status_topic(topic) or (
        with_keypoints and layout.is_keypoints_topic(topic))


class Replayer:
    """Publishes a recording on ``keys`` through ``session``."""

    def __init__(self, session, keys: Keys, *, rate: float | None = 1.0, keypoints: bool = True) -> None:
        import zenoh

        if rate is not None and not rate > 0:
            raise ValueError(f"rate: must be > 0 (or max), got {rate}")
        self.session, self.keys, self.rate, self.keypoints = session, keys, rate, keypoints
        self._block = zenoh.CongestionControl.BLOCK
        self._pubs: dict[str, object] = {}

    def _pub(self, key: str):
        if key not in self._pubs:
            self._pubs[key] = self.session.declare_publisher(key, congestion_control=self._block)
        return self._pubs[key]

    def _pace(self, log_time: int, first: list[int | None], wall0: float) -> None:
        if self.rate is None:
            return
        if first[0] is None:
            first[0] = log_time
        due = wall0 + (log_time - first[0]) / 1e9 / self.rate
        delay = due - time.monotonic()
        if delay > 0:
            time.sleep(delay)

    def run(self, path: str | Path, stop: Callable[[], bool] = lambda: False) -> ReplayStats:
        src = resolve_recording(path)
        stats = ReplayStats()
        wall0, first = time.monotonic(), [None]
        for topic, msg in iter_messages(src, lambda t: _wanted(t, self.keypoints)):
            if stop():
                break
            camera = layout.camera_of_topic(topic)
            if layout.is_status_topic(topic):  # stamped with the host clock: not used for pacing
                self._pub(self.keys.status(camera)).put(msg.data)
                stats.status += 1
                continue
            self._pace(msg.log_time, first, wall0)
            if layout.is_image_topic(topic):
                att = FrameMeta(frame_id=int(msg.sequence), sent_ns=time.time_ns(), replay=True)
                self._pub(self.keys.image(camera)).put(msg.data, attachment=att.to_bytes())
                stats.frames += 1
                stats.per_camera[camera] = stats.per_camera.get(camera, 0) + 1
            else:
                self._pub(self.keys.keypoints(camera)).put(msg.data)
                stats.keypoints += 1
        stats.duration_s = time.monotonic() - wall0
        return stats
