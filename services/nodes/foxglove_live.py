"""Live view in Foxglove: a Foxglove WebSocket server (``foxglove-sdk``) relaying the live bus.

Channels, all in Foxglove's own types except the status (names as in a trial MCAP, so one layout
serves both):

- ``/camera/<cam>/image`` ``foxglove.CompressedImage``: the camera's frames, at most
  ``preview_fps`` per camera (the bus payload is forwarded as it is);
- ``/camera/<cam>/annotations`` ``foxglove.ImageAnnotations``: the keypoints of the forwarded frames;
- ``/camera/<cam>/calibration`` ``foxglove.CameraCalibration``: the rig, when one is given, every
  ``calibration_interval_s`` (a client that connects later gets it too);
- ``/camera/<cam>/status`` JSON: the camera status messages.

The server binds to loopback only: the Foxglove WebSocket protocol has no authentication, so the relay
never exposes itself. It is reached from another machine only through an authenticated tunnel (SSH; see
docs/viewers.md), which puts it behind the lab's own accounts.
Subscriber callbacks only count, compare and hand bytes to the server (no decoding of images).
"""

from __future__ import annotations

import ipaddress
import logging
import threading
import time
from collections import deque
from dataclasses import dataclass

from gaitcap.acquisition.recording import layout
from gaitcap.acquisition.recording.foxglove_messages import camera_calibration, image_annotations, schema_data
from gaitcap.reconstruction.camera import Rig
from gaitcap.services.bus.messages import ImageFrame, Keypoints
from gaitcap.services.bus.session import BusConfig

log = logging.getLogger(__name__)

RECENT_FRAMES = 64  # per camera: forwarded frame timestamps whose keypoints are still expected


@dataclass(frozen=True)
class FoxgloveLiveConfig:
    """host: loopback address to bind (127.0.0.1, ::1 or localhost); port: TCP port (0: any free one);
    preview_fps: frames per second and camera forwarded (the bus carries 30);
    calibration_interval_s: how often the rig's calibrations are re-sent, s."""

    host: str = "127.0.0.1"
    port: int = 8765
    preview_fps: float = 5.0
    calibration_interval_s: float = 2.0

    def __post_init__(self) -> None:
        try:
            loopback = self.host == "localhost" or ipaddress.ip_address(self.host).is_loopback
        except ValueError:
            raise ValueError(f"host: {self.host!r} is not an IP address or localhost") from None
        if not loopback:
            raise ValueError(f"host: {self.host} is not loopback; the Foxglove WebSocket protocol has no "
                             "authentication: bind to 127.0.0.1 and reach it through an SSH tunnel")
        if not 0 <= self.port <= 65535:
            raise ValueError(f"port: must be 0..65535, got {self.port}")
        if not self.preview_fps > 0:
            raise ValueError(f"preview_fps: must be > 0, got {self.preview_fps}")
        if not self.calibration_interval_s > 0:
            raise ValueError(f"calibration_interval_s: must be > 0 s, got {self.calibration_interval_s}")


def _sdk():
    try:
        import foxglove
    except ImportError:
        raise ValueError("the live Foxglove view needs the foxglove-sdk package: pip install 'gaitcap[viewer]'") from None
    return foxglove


class FoxgloveRelay:
    """Relays frames (reduced rate), keypoints as annotations, camera status and the rig to Foxglove."""

    def __init__(self, session, bus: BusConfig, config: FoxgloveLiveConfig = FoxgloveLiveConfig(),
                 *, rig: Rig | None = None) -> None:
        foxglove = _sdk()
        self.bus, self.config, self.rig = bus, config, rig
        self._context = foxglove.Context()
        self._channels: dict[str, object] = {}
        self._lock = threading.Lock()
        self._last_frame_ns: dict[str, int] = {}
        self._forwarded: dict[str, deque] = {}
        self.frames_in = self.frames_out = self.annotations_out = 0
        self.server = foxglove.start_server(name="gaitcap live", host=config.host, port=config.port,
                                            context=self._context)
        for camera in rig.names if rig is not None else ():  # advertised before any frame: none is missed
            for topic in (layout.image_topic(camera), layout.annotations_topic(camera),
                          layout.camera_calibration_topic(camera), layout.status_topic(camera)):
                self._channel(topic)
        self._stop = threading.Event()
        self._subs = [session.declare_subscriber(bus.keys.image(), self._on_image),
                      session.declare_subscriber(bus.keys.keypoints(), self._on_keypoints),
                      session.declare_subscriber(bus.keys.status(), self._on_status)]
        self._calibrations = threading.Thread(target=self._send_calibrations, name="foxglove-calibration",
                                              daemon=True)
        self._calibrations.start()
        log.info("Foxglove live view on ws://%s:%d", config.host, self.port)

    @property
    def port(self) -> int:
        return self.server.port

    def _channel(self, topic: str):
        with self._lock:
            if topic not in self._channels:
                foxglove = _sdk()
                proto = layout.protobuf_schema_of_topic(topic)
                if proto is not None:
                    schema = foxglove.Schema(name=proto, encoding="protobuf", data=schema_data(proto))
                    self._channels[topic] = foxglove.Channel(topic, schema=schema, message_encoding="protobuf",
                                                             context=self._context)
                else:
                    self._channels[topic] = foxglove.Channel(topic, message_encoding="json", context=self._context)
            return self._channels[topic]

    # -- bus callbacks ------------------------------------------------------------------------------
    def _on_image(self, sample) -> None:
        camera = self.bus.keys.camera_of(str(sample.key_expr))
        now = time.monotonic_ns()
        self.frames_in += 1
        if now - self._last_frame_ns.get(camera, -(10**18)) < 1e9 / self.config.preview_fps:
            return
        att = sample.attachment.to_bytes() if sample.attachment is not None else None
        try:
            frame = ImageFrame.from_bytes(sample.payload.to_bytes(), att, camera=camera)
        except ValueError as exc:
            log.warning("camera %s: frame not relayed (%s)", camera, exc)
            return
        self._last_frame_ns[camera] = now
        self._forwarded.setdefault(camera, deque(maxlen=RECENT_FRAMES)).append(frame.timestamp_ns)
        self._channel(layout.image_topic(camera)).log(frame.payload, log_time=frame.timestamp_ns)
        self.frames_out += 1

    def _on_keypoints(self, sample) -> None:
        camera = self.bus.keys.camera_of(str(sample.key_expr))
        try:
            msg = Keypoints.from_bytes(sample.payload.to_bytes())
            if msg.timestamp_ns not in self._forwarded.get(camera, ()):
                return  # its frame was not relayed
            data = image_annotations(msg)
        except ValueError as exc:
            log.warning("camera %s: keypoints not relayed (%s)", camera, exc)
            return
        self._channel(layout.annotations_topic(camera)).log(data, log_time=msg.timestamp_ns)
        self.annotations_out += 1

    def _on_status(self, sample) -> None:
        camera = self.bus.keys.camera_of(str(sample.key_expr))
        self._channel(layout.status_topic(camera)).log(sample.payload.to_bytes(), log_time=time.time_ns())

    def _send_calibrations(self) -> None:
        while self.rig is not None and not self._stop.is_set():
            now = time.time_ns()
            for camera in self.rig:
                self._channel(layout.camera_calibration_topic(camera.name)).log(
                    camera_calibration(camera, time_ns=now), log_time=now)
            self._stop.wait(self.config.calibration_interval_s)

    def close(self) -> None:
        self._stop.set()
        for sub in self._subs:
            sub.undeclare()
        self._calibrations.join(5)
        self.server.stop()
