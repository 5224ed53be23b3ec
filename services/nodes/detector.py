"""Detector node: 2D keypoints for every frame of its cameras on the bus.

Subscribes to ``<prefix>/camera/<cam>/image`` for the cameras it serves (:class:`CameraSelection`: all,
a list, or shard K of N so that several detector nodes on several hosts share a rig's cameras), hands the
JPEGs to a :class:`~gaitcap.acquisition.detectors.pool.DetectorPool` (worker processes, each with its
own model, frames routed by camera; or one in-process worker for a detector object) and publishes
:class:`~gaitcap.services.bus.messages.Keypoints` on ``<prefix>/keypoints/<cam>``. When detection falls
behind, the pool skips the oldest queued frames and counts them, so live keypoints never lag without
bound; the recorder still records every image and the worker completes the rest after Stop.

About once per ``status_period_s`` it publishes its live coverage (:class:`DetectorStatus` on
``<prefix>/detector/status/<node>``): per camera the frames received, detected, skipped, lost (with a
worker that died) and failed, and the lag (s) from the camera node's send to the keypoints' publication.
"""

from __future__ import annotations

import collections
import logging
import threading
import time
import zlib
from dataclasses import dataclass

import numpy as np
from gaitcap.acquisition.detectors.pool import DetectorPool, DetectResult, FrameTask
from gaitcap.services.bus.messages import DetectorStatus, ImageFrame, Keypoints
from gaitcap.services.bus.session import BusConfig, declare_alive

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class CameraSelection:
    """Which cameras a detector node serves: ``names`` (empty: any), and/or shard ``shard`` of ``shards``
    (a camera belongs to shard ``crc32(name) % shards``; the same on every host)."""

    names: tuple[str, ...] = ()
    shard: int = 0
    shards: int = 1

    def __post_init__(self) -> None:
        if self.shards < 1 or not 0 <= self.shard < self.shards:
            raise ValueError(f"--shard: expected K/N with 0 <= K < N, got {self.shard}/{self.shards}")

    @classmethod
    def parse(cls, cameras: str | None, shard: str | None) -> CameraSelection:
        """From ``--cameras a,b`` and ``--shard K/N`` (ValueError naming the option)."""
        names = tuple(c for c in (cameras or "").split(",") if c)
        if not shard:
            return cls(names)
        k, sep, n = shard.partition("/")
        try:
            return cls(names, int(k), int(n))
        except ValueError:
            raise ValueError(f"--shard: expected K/N (for example 0/2), got {shard!r}") from None

    def wants(self, camera: str) -> bool:
        if self.names and camera not in self.names:
            return False
        return self.shards == 1 or zlib.crc32(camera.encode()) % self.shards == self.shard

    def frame_of(self, keys, sample) -> ImageFrame | None:
        """The camera frame in bus ``sample`` (published on an image key of ``keys``); None when its camera
        is not one of this selection's; ValueError naming what is wrong with the key or the frame."""
        camera = keys.camera_of(str(sample.key_expr))
        if not self.wants(camera):
            return None
        att = sample.attachment.to_bytes() if sample.attachment is not None else None
        return ImageFrame.from_bytes(sample.payload.to_bytes(), att, camera=camera)


class Coverage:
    """Per-camera counts and lag of a detector node (thread-safe)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.received: collections.Counter = collections.Counter()
        self.detected: collections.Counter = collections.Counter()
        self.failed: collections.Counter = collections.Counter()
        self.lag_s: dict[str, float] = {}

    def count(self, counter: collections.Counter, camera: str) -> None:
        with self._lock:
            counter[camera] += 1

    def detected_one(self, camera: str, lag_s: float) -> None:
        with self._lock:
            self.detected[camera] += 1
            self.lag_s[camera] = max(0.0, lag_s)

    def rows(self, skipped: collections.Counter, lost: collections.Counter) -> dict[str, dict]:
        with self._lock:
            cams = sorted(set(self.received) | set(self.failed) | set(skipped) | set(lost))
            return {c: {"received": self.received[c], "detected": self.detected[c], "skipped": skipped[c],
                        "lost": lost[c], "failed": self.failed[c],
                        "lag_s": round(self.lag_s[c], 3) if c in self.lag_s else None} for c in cams}


class DetectorNode:
    """Runs a detector pool on the bus frames of ``cameras`` until :meth:`close`.

    ``detectors``: a :class:`DetectorPool`, or a detector object (then one in-process worker)."""

    def __init__(self, session, bus: BusConfig, node: str, detectors, *, cameras: CameraSelection | None = None,
                 max_queue: int = 600, status_period_s: float = 1.0) -> None:
        if max_queue < 1 or status_period_s <= 0:
            raise ValueError("max_queue must be >= 1 and status_period_s > 0")
        self.session, self.bus, self.node = session, bus, node
        self.cameras = cameras or CameraSelection()
        self.pool = detectors if isinstance(detectors, DetectorPool) else DetectorPool.in_process(
            detectors, None, max_pending=max_queue)
        self.pool.on_result = self._publish
        self.skeleton = self.pool.skeleton
        self.coverage = Coverage()
        self._closed = threading.Event()
        self._pubs: dict[str, object] = {}
        self._pub_lock = threading.Lock()
        self._status_pub = session.declare_publisher(bus.keys.detector_status(node))
        keys = [bus.keys.image(c) for c in self.cameras.names] or [bus.keys.image()]
        self._subs = [session.declare_subscriber(k, self._on_image) for k in keys]
        self._status = threading.Thread(target=self._status_loop, args=(status_period_s,), daemon=True,
                                        name="detector-status")
        self._status.start()
        self._token = declare_alive(session, bus, node)

    # totals, as the node's log and tests read them
    @property
    def detected(self) -> int:
        return sum(self.coverage.detected.values())

    @property
    def failed(self) -> int:
        return sum(self.coverage.failed.values())

    @property
    def skipped(self) -> int:
        return sum(self.pool.counts.skipped.values())

    @property
    def lost(self) -> int:
        return sum(self.pool.counts.lost.values())

    def _on_image(self, sample) -> None:
        try:
            frame = self.cameras.frame_of(self.bus.keys, sample)
        except ValueError as exc:
            log.warning("frame on %s refused: %s", sample.key_expr, exc)
            return
        if frame is None:
            return
        camera = frame.camera
        self.coverage.count(self.coverage.received, camera)
        self.pool.submit(FrameTask(camera, frame.frame_id, frame.timestamp_ns, frame.meta.sent_ns, frame.jpeg))

    def _publisher(self, camera: str):
        import zenoh

        with self._pub_lock:
            if camera not in self._pubs:
                self._pubs[camera] = self.session.declare_publisher(
                    self.bus.keys.keypoints(camera), congestion_control=zenoh.CongestionControl.BLOCK)
            return self._pubs[camera]

    def _publish(self, result: DetectResult) -> None:
        task = result.task
        if result.error is not None:
            self.coverage.count(self.coverage.failed, task.camera)
            log.warning("detection failed on camera %s frame %d: %s", task.camera, task.frame_id, result.error)
            return
        people = result.people
        if people.size:  # JSON has no NaN: a joint with any non-finite value becomes [0, 0, conf 0]
            people = np.where(np.isfinite(people).all(axis=-1, keepdims=True), people, 0.0)
        out = Keypoints(camera=task.camera, frame_id=task.frame_id, timestamp_ns=task.timestamp_ns,
                        skeleton=self.skeleton, people=np.round(people, 4).tolist(),
                        detector_ms=round(result.detector_ms, 3))
        self._publisher(task.camera).put(out.to_bytes())
        self.coverage.detected_one(task.camera, (time.time_ns() - task.sent_ns) / 1e9)

    def status(self) -> DetectorStatus:
        """The node's live coverage now."""
        return DetectorStatus(node=self.node, time_ns=time.time_ns(), workers=len(self.pool.alive_workers()),
                              pool=self.pool.size,
                              cameras=self.coverage.rows(self.pool.counts.skipped, self.pool.counts.lost))

    def _status_loop(self, period_s: float) -> None:
        while not self._closed.wait(period_s):
            try:
                self._status_pub.put(self.status().to_bytes())
            except Exception:  # the bus closing under us; the next period tries again
                log.debug("detector status not published", exc_info=True)

    def wait_idle(self, timeout_s: float = 10.0) -> bool:
        """Wait until no frame is queued or being detected (tests, shutdown)."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            if not self.pool.busy():
                return True
            time.sleep(0.02)
        return False

    def close(self) -> None:
        for sub in self._subs:
            sub.undeclare()
        self.pool.close()
        self._closed.set()
        self._status.join(timeout=5)
        try:
            self._status_pub.put(self.status().to_bytes())
        except Exception:  # the session may already be closing
            log.debug("final detector status not published", exc_info=True)
        self._token.undeclare()
        log.info("detector node %s: %d detected, %d skipped, %d lost, %d failed", self.node, self.detected,
                 self.skipped, self.lost, self.failed)
