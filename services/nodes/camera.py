"""Camera node: drives the cameras of one host and publishes their JPEG frames and status on the bus.

One thread per camera: frames -> JPEG -> ``foxglove.CompressedImage`` on ``<prefix>/camera/<cam>/image``
(the camera timestamp in the protobuf; a :class:`~gaitcap.services.bus.messages.FrameMeta` attachment: frame id,
send time). A status thread publishes each camera's
status once per second and when a camera stops or fails; a camera that fails mid-trial does not stop
the others. The node holds the liveliness token ``<prefix>/alive/<node>``.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Sequence

from gaitcap.acquisition.drivers.base import CameraDriver, Frame
from gaitcap.acquisition.encoding import encode_jpeg
from gaitcap.services.bus.messages import CameraStatus, ImageFrame
from gaitcap.services.bus.session import BusConfig, declare_alive

log = logging.getLogger(__name__)


class CameraNode:
    """Publishes frames of ``drivers`` (opened and configured) until they end or :meth:`stop`."""

    def __init__(self, session, bus: BusConfig, node: str, drivers: Sequence[CameraDriver], *,
                 jpeg_quality: int = 90, status_interval_s: float = 1.0) -> None:
        import zenoh

        if not drivers:
            raise ValueError(f"camera node {node}: no cameras")
        names = [d.name for d in drivers]
        if len(set(names)) != len(names):
            raise ValueError(f"camera node {node}: duplicate camera names {names}")
        self.session, self.bus, self.node = session, bus, node
        self.drivers = list(drivers)
        self.jpeg_quality = jpeg_quality
        self.status_interval_s = status_interval_s
        keys = bus.keys
        block = zenoh.CongestionControl.BLOCK
        self._image_pubs = {d.name: session.declare_publisher(keys.image(d.name), congestion_control=block)
                            for d in drivers}
        self._status_pubs = {d.name: session.declare_publisher(keys.status(d.name)) for d in drivers}
        self._token = declare_alive(session, bus, node)
        self._stop = threading.Event()
        self.published: dict[str, int] = {d.name: 0 for d in drivers}

    def publish_frame(self, frame: Frame) -> None:
        jpeg = frame.jpeg if frame.jpeg is not None else encode_jpeg(frame.image, quality=self.jpeg_quality)
        msg = ImageFrame.build(jpeg, camera=frame.camera, timestamp_ns=frame.timestamp_ns, frame_id=frame.frame_id,
                               sent_ns=time.time_ns(), ptp_jump=bool(frame.ptp_jump))
        self._image_pubs[frame.camera].put(msg.payload, attachment=msg.meta.to_bytes())
        self.published[frame.camera] += 1

    def publish_status(self, driver: CameraDriver) -> None:
        status = CameraStatus.of_driver(driver.status().to_dict(), node=self.node, time_ns=time.time_ns(),
                                        published=self.published[driver.name])
        self._status_pubs[driver.name].put(status.to_bytes())

    def _run_camera(self, driver: CameraDriver) -> None:
        try:
            for frame in driver.frames():
                if self._stop.is_set():
                    break
                self.publish_frame(frame)
        except Exception as exc:  # a failing camera must not take the others down
            log.exception("camera %s failed", driver.name)
            st = driver.status()
            st.state, st.error = "error", f"camera {driver.name}: {exc}"
        finally:
            self.publish_status(driver)

    def _status_loop(self, threads: list[threading.Thread]) -> None:
        while any(t.is_alive() for t in threads) and not self._stop.wait(self.status_interval_s):
            for d in self.drivers:
                self.publish_status(d)

    def run(self, start_at_ns: int | None = None) -> dict[str, int]:
        """Start every camera at ``start_at_ns`` (wall/PTP clock, ns; None: now + 250 ms) and publish
        until all cameras end or :meth:`stop` is called. Returns frames published per camera."""
        at = time.time_ns() + 250_000_000 if start_at_ns is None else int(start_at_ns)
        for d in self.drivers:
            d.start(at)
        threads = [threading.Thread(target=self._run_camera, args=(d,), name=f"cam-{d.name}", daemon=True)
                   for d in self.drivers]
        for t in threads:
            t.start()
        self._status_loop(threads)
        for t in threads:
            t.join()
        for d in self.drivers:
            d.stop()
            self.publish_status(d)
        log.info("camera node %s done: %s", self.node, self.published)
        return dict(self.published)

    def stop(self) -> None:
        self._stop.set()
        for d in self.drivers:
            d.stop()

    def close(self) -> None:
        self._token.undeclare()

