"""Detector node: 2D keypoints for every frame on the bus.

Subscribes to ``<prefix>/camera/*/image``, decodes the JPEG, runs a
:class:`~gaitcap.acquisition.detectors.base.Detector` and publishes
:class:`~gaitcap.services.bus.messages.Keypoints` on ``<prefix>/keypoints/<cam>``. The subscriber callback only
enqueues; ``workers`` threads decode JPEGs in parallel (OpenCV releases the GIL) while ``detect`` calls
are serialised (a model interpreter is not thread-safe). When detection falls behind
by more than ``max_queue`` frames the oldest frames are skipped and counted (``skipped``), so live
keypoints never lag without bound; the recorder still records every image.
"""

from __future__ import annotations

import collections
import logging
import threading
import time

import numpy as np
from gaitcap.services.bus.messages import ImageFrame, Keypoints
from gaitcap.services.bus.session import BusConfig, declare_alive

log = logging.getLogger(__name__)


class DetectorNode:
    """Runs ``detector`` on every frame of the bus until :meth:`close`."""

    def __init__(self, session, bus: BusConfig, node: str, detector, *, workers: int = 1,
                 max_queue: int = 600) -> None:
        import zenoh

        if workers < 1 or max_queue < 1:
            raise ValueError("workers and max_queue must be >= 1")
        self.session, self.bus, self.node, self.detector = session, bus, node, detector
        self.skeleton = detector.skeleton.name
        self.max_queue = max_queue
        self._pending: collections.deque = collections.deque()
        self._cond = threading.Condition()
        self._detect_lock = threading.Lock()
        self._closed = False
        self.detected = 0
        self.skipped = 0
        self.failed = 0
        self._block = zenoh.CongestionControl.BLOCK
        self._pubs: dict[str, object] = {}
        self._sub = session.declare_subscriber(bus.keys.image(), self._on_image)
        self._threads = [threading.Thread(target=self._work, name=f"detect-{i}", daemon=True) for i in range(workers)]
        for t in self._threads:
            t.start()
        self._token = declare_alive(session, bus, node)

    def _on_image(self, sample) -> None:
        att = sample.attachment.to_bytes() if sample.attachment is not None else None
        with self._cond:
            if len(self._pending) >= self.max_queue:
                self._pending.popleft()
                self.skipped += 1
            self._pending.append((str(sample.key_expr), sample.payload.to_bytes(), att))
            self._cond.notify()

    def _publisher(self, camera: str):
        if camera not in self._pubs:
            self._pubs[camera] = self.session.declare_publisher(self.bus.keys.keypoints(camera),
                                                                congestion_control=self._block)
        return self._pubs[camera]

    def _work(self) -> None:
        while True:
            with self._cond:
                while not self._pending and not self._closed:
                    self._cond.wait(0.5)
                if self._closed and not self._pending:
                    return
                key, payload, att = self._pending.popleft()
            try:
                self._detect(key, payload, att)
            except Exception as exc:  # one bad frame must not stop the node
                self.failed += 1
                log.warning("detection failed on %s: %s", key, exc)

    def _detect(self, key: str, payload: bytes, att: bytes | None) -> None:
        frame = ImageFrame.from_bytes(payload, att, camera=self.bus.keys.camera_of(key))
        image = frame.image()
        with self._detect_lock:
            t0 = time.perf_counter()
            people = np.asarray(self.detector.detect(image, camera=frame.camera, frame_id=frame.frame_id,
                                                     timestamp_ns=frame.timestamp_ns), dtype=np.float64)
            ms = (time.perf_counter() - t0) * 1e3
        if people.size:  # JSON has no NaN: a joint with any non-finite value becomes [0, 0, conf 0]
            people = np.where(np.isfinite(people).all(axis=-1, keepdims=True), people, 0.0)
        out = Keypoints(camera=frame.camera, frame_id=frame.frame_id, timestamp_ns=frame.timestamp_ns,
                        skeleton=self.skeleton, people=np.round(people, 4).tolist(), detector_ms=round(ms, 3))
        self._publisher(frame.camera).put(out.to_bytes())
        self.detected += 1

    def wait_idle(self, timeout_s: float = 10.0) -> bool:
        """Wait until the queue is empty (tests, shutdown)."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            with self._cond:
                if not self._pending:
                    return True
            time.sleep(0.02)
        return False

    def close(self) -> None:
        self._sub.undeclare()
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        for t in self._threads:
            t.join(timeout=5)
        self._token.undeclare()
        log.info("detector node %s: %d detected, %d skipped, %d failed", self.node, self.detected,
                 self.skipped, self.failed)
