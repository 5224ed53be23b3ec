"""GigE Vision cameras through Aravis (the open-source GigE Vision / GenICam stack), no vendor SDK.

Aravis speaks the protocol itself: GVCP (control, UDP port 3956), GVSP (the image stream over UDP, with
packet resend requests) and the cameras' GenICam features. It drives FLIR (and other) GigE Vision cameras
without Spinnaker, and its Debian package ships ``arv-fake-gv-camera-0.8``, a camera simulator that speaks
the same protocol over real UDP (the tests and ``bench/gige.py`` run against it).

Life cycle (:mod:`gaitcap.acquisition.drivers.base`): :meth:`AravisCamera.open` finds the device by
serial number, device id or IP address (a device that never answers is named with what was found);
:meth:`~AravisCamera.configure` sets continuous free-run acquisition, exposure (auto off), gain (auto
off), frame rate, pixel format, region, packet size and inter-packet delay, and reads back what the
camera took; :meth:`~AravisCamera.start` starts the stream; :meth:`~AravisCamera.frames` yields
complete frames with the device timestamp (ns) and a frame id from the device's block id (16-bit GigE
Vision 1.x ids unwrapped); incomplete frames are counted and dropped, so they show as frame-id gaps
(``incomplete``; those whose packets came before the synchronised start are not trial frames and are
counted apart, ``incomplete_before_start``; a buffer Aravis hands back unfilled, status CLEARED, carries no
frame at all and is counted as ``empty_buffers``). A
device whose timestamps show more frame periods passing than its block ids (a camera that skipped frames
itself, as the software fake camera does on a loaded host) has its frame ids advanced by the periods, the
skipped ones counted (``device_skipped``), so frame ids stay one per period on every camera (a frame up to
1.5 periods late is taken as late, not as a skip; only on a device clock on the host's epoch).

Receiving on a loaded host (:class:`StreamTuning`): the stream's socket receive buffer is set to several
frames (Aravis leaves the system default, 208 KiB, less than one 512 x 512 frame: a receiver thread
descheduled for a moment overflows it and packets are lost; the kernel caps the size at
``net.core.rmem_max``, and the status says what was asked and the cap), and an unfinished frame is kept for
several frame periods (Aravis: 100 ms) before it is given up, so a frame whose sender or receiver was
descheduled mid-frame is not declared incomplete while its packets are still coming. The stream always
receives through its UDP socket: as root, Aravis 0.8.26 would use a packet socket (AF_PACKET) instead,
which takes every packet on the interface between its bind and its filter; the first of them sets the
stream's frame count, so a stray one (the bus, another camera's control traffic) made Aravis hand back
empty buffers or discard the camera's real frames as late for seconds.

Synchronised start (:mod:`gaitcap.acquisition.drivers.aravis_action`): where the device takes scheduled
action commands (its GVCP capabilities, action features, the Action1 trigger and a timestamp latch, all
read from it), acquisition start is armed on the action and one scheduled action command, sent by gaitcap
over GVCP (Aravis 0.8.26 has no sender), starts it at the start instant on the device clock; otherwise
(the fake camera) the start is a software start, and the status says which and why (``start_sync``,
``action_commands``). When the device clock is on the host's epoch (PTP-synchronised to the same grandmaster as the host, or
the fake camera, whose clock is the host's), frames stamped before ``at_ns`` are discarded and frame
ids count camera periods from ``at_ns``, so every camera numbers the same instant alike; otherwise frame
ids count from the first frame and the status says so. PTP is enabled and reported where the device has
the feature (``PtpEnable``/``PtpStatus`` or ``GevIEEE1588``/``GevIEEE1588Status``); where it has not
(the fake camera), the status says ``ptp: not supported by the device``. Nothing is assumed silently.

Aravis (PyGObject and the ``Aravis-0.8`` typelib) is imported lazily; a missing piece raises
:class:`AravisMissing` naming it and the packages that provide it.
"""

from __future__ import annotations

import logging
import os
import socket
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from gaitcap.acquisition.drivers.aravis_action import ActionSupport, action_support, scheduled_start
from gaitcap.acquisition.drivers.base import CaptureSettings, DriverStatus, Frame, is_ptp_jump
from gaitcap.acquisition.drivers.flir import to_bgr

log = logging.getLogger(__name__)

SUPPORTED_FORMATS = ("BayerRG8", "BayerBG8", "BayerGR8", "BayerGB8", "Mono8", "RGB8", "BGR8")
GEV1_BLOCK_IDS = 65535  # GigE Vision 1.x block ids: 16 bits, 0 reserved, 65535 wraps to 1
CLOCK_ON_HOST_EPOCH_NS = 2_000_000_000  # a device clock within 2 s of the host's shares its epoch
_PTP_FEATURES = (("PtpEnable", "PtpStatus"), ("GevIEEE1588", "GevIEEE1588Status"))
HEARTBEAT_TIMEOUT_REGISTER = 0x0938  # GigE Vision bootstrap register (GevHeartbeatTimeout), ms, on every device
START_SYNC = ("software start (the device takes no scheduled action command: see action_commands); frame ids "
              "aligned on the device timestamps")
_STREAM_COUNTERS = {"n_missing_packets": "missing_packets", "n_resend_requests": "resend_requests",
                    "n_resent_packets": "resent_packets", "n_received_packets": "received_packets",
                    "n_timeouts": "stream_timeouts", "n_missing_frames": "missing_frames",
                    "n_underruns": "underruns", "n_ignored_packets": "ignored_packets"}
RMEM_MAX_PATH = Path("/proc/sys/net/core/rmem_max")


class AravisMissing(ValueError):
    """PyGObject or the Aravis 0.8 introspection data is not installed."""


def import_aravis():
    """The ``Aravis`` module (0.8) or :class:`AravisMissing` naming what is missing."""
    try:
        import gi
    except ImportError as exc:
        raise AravisMissing(
            "the Aravis driver needs PyGObject (the 'gi' module): pip install 'PyGObject>=3.42,<3.51' in this "
            "environment (it builds against the Debian packages libgirepository1.0-dev, libcairo2-dev and "
            f"pkg-config; deploy/bootstrap.sh installs all of it) ({exc})") from None
    try:
        gi.require_version("Aravis", "0.8")
        from gi.repository import Aravis
    except (ValueError, ImportError) as exc:
        raise AravisMissing(
            "the Aravis driver needs the Aravis 0.8 introspection data (Debian package gir1.2-aravis-0.8; "
            f"the fake camera is in aravis-tools) ({exc})") from None
    return Aravis


@dataclass(frozen=True)
class DeviceInfo:
    """One GigE Vision device as discovered: ``device_id`` (Aravis id), ``serial``, ``address`` (IPv4)."""

    device_id: str
    serial: str
    address: str
    vendor: str
    model: str

    def matches(self, wanted: str) -> bool:
        return wanted in (self.serial, self.device_id, self.address)


def discover(aravis: Any | None = None) -> list[DeviceInfo]:
    """Every GigE Vision device answering discovery on this host's interfaces (about 1 s)."""
    arv = aravis or import_aravis()
    arv.update_device_list()
    return [DeviceInfo(device_id=arv.get_device_id(i), serial=arv.get_device_serial_nbr(i) or "",
                       address=arv.get_device_address(i) or "", vendor=arv.get_device_vendor(i) or "",
                       model=arv.get_device_model(i) or "")
            for i in range(arv.get_n_devices()) if arv.get_device_protocol(i) == "GigEVision"]


def _is_ipv4(text: str) -> bool:
    parts = text.split(".")
    return len(parts) == 4 and all(p.isdigit() and int(p) < 256 for p in parts)


@dataclass(frozen=True)
class StreamTuning:
    """How the GVSP stream receives, for a host that may be loaded.

    Attributes:
        socket_buffer_frames: the stream socket's receive buffer holds this many frames (payload bytes;
            capped by the kernel at ``net.core.rmem_max``: raise it for many or large cameras,
            docs/lab-setup.md).
        frame_retention_periods: an unfinished frame is given up (incomplete) after no packet for this many
            frame periods, and never sooner than ``min_frame_retention_ms``.
        min_frame_retention_ms: the least wait for a frame's missing packets (Aravis's own: 100 ms).
    """

    socket_buffer_frames: int = 4
    frame_retention_periods: float = 4.0
    min_frame_retention_ms: int = 100

    def __post_init__(self) -> None:
        if self.socket_buffer_frames < 1 or self.frame_retention_periods <= 0 or self.min_frame_retention_ms < 1:
            raise ValueError(f"stream tuning: socket_buffer_frames >= 1, frame_retention_periods > 0 and "
                             f"min_frame_retention_ms >= 1 needed, got {self.socket_buffer_frames}, "
                             f"{self.frame_retention_periods}, {self.min_frame_retention_ms}")

    def socket_buffer_bytes(self, payload_bytes: int) -> int:
        """The receive buffer asked for, in bytes."""
        return int(self.socket_buffer_frames * payload_bytes)

    def frame_retention_us(self, period_ns: int) -> int:
        """How long an unfinished frame is kept after its last packet, in us."""
        return int(max(self.min_frame_retention_ms * 1000, self.frame_retention_periods * period_ns / 1000))


def rmem_max_bytes() -> int | None:
    """The kernel's cap on a socket receive buffer (``net.core.rmem_max``, bytes; None where unreadable)."""
    try:
        return int(RMEM_MAX_PATH.read_text().strip())
    except (OSError, ValueError):
        return None


@dataclass(frozen=True)
class AravisOptions:
    """GigE Vision transport and imaging options beyond :class:`CaptureSettings`.

    Attributes:
        packet_size_bytes: GVSP packet size (GevSCPSPacketSize; 9000 = jumbo frames, the NIC's MTU must
            allow it); None: Aravis negotiates the largest that passes.
        packet_delay_ns: inter-packet delay (GevSCPD, set in ns; Aravis converts to device ticks) so many
            cameras share one link.
        gain_db: fixed gain (auto off); None: the device's.
        frame_timeout_ms: wait for one frame at most this long; ``stall_timeouts`` waits in a row with no
            frame = the camera is gone (named, state ``error``).
        buffers: stream buffers queued to Aravis.
        packet_resend: ask the camera to resend lost packets (GVCP PACKETRESEND).
        max_frames: end the stream after this many delivered frames (None: until stopped).
        tuning: how the stream receives (:class:`StreamTuning`).
        heartbeat_timeout_ms: the camera keeps this host in control while it hears from it within this
            long (GevHeartbeatTimeout; Aravis reads the control register every second). Cameras default to
            3000 ms: a loaded host whose heartbeat thread is descheduled longer loses control and the
            camera stops streaming. Longer: a crashed node holds the camera that long before another may
            open it.
    """

    packet_size_bytes: int | None = 1400
    packet_delay_ns: int = 0
    gain_db: float | None = None
    frame_timeout_ms: int = 1000
    stall_timeouts: int = 3
    buffers: int = 16
    packet_resend: bool = True
    max_frames: int | None = None
    tuning: StreamTuning = StreamTuning()
    heartbeat_timeout_ms: int | None = 10_000

    def __post_init__(self) -> None:
        if self.packet_size_bytes is not None and not 576 <= self.packet_size_bytes <= 16000:
            raise ValueError(f"packet_size_bytes: expected 576..16000 bytes, got {self.packet_size_bytes}")
        if self.packet_delay_ns < 0:
            raise ValueError(f"packet_delay_ns: must be >= 0, got {self.packet_delay_ns}")
        if self.heartbeat_timeout_ms is not None and not 500 <= self.heartbeat_timeout_ms <= 600_000:
            raise ValueError(f"heartbeat_timeout_ms: expected 500..600000 ms, got {self.heartbeat_timeout_ms}")
        if self.frame_timeout_ms <= 0 or self.stall_timeouts < 1 or self.buffers < 2:
            raise ValueError(f"frame_timeout_ms > 0, stall_timeouts >= 1 and buffers >= 2 needed, got "
                             f"{self.frame_timeout_ms}, {self.stall_timeouts}, {self.buffers}")


class BlockIds:
    """Unwraps device block ids (16-bit on GigE Vision 1.x: 1..65535, then 1 again) into a counter."""

    def __init__(self) -> None:
        self._last_raw: int | None = None
        self.count = 0

    def next(self, raw: int) -> int:
        """The unwrapped id of block ``raw``; the first block is 0."""
        if self._last_raw is not None:
            step = raw - self._last_raw
            if step <= 0 and self._last_raw <= GEV1_BLOCK_IDS and self._last_raw - raw > GEV1_BLOCK_IDS // 2:
                step += GEV1_BLOCK_IDS  # 65535 -> 1 (0 is never sent)
            self.count += max(step, 0)
        self._last_raw = raw
        return self.count


def _gerror_text(exc: Exception) -> str:
    return getattr(exc, "message", None) or str(exc)


def _size_receive_buffer(port: int, size_bytes: int) -> int | None:
    """Set SO_RCVBUF of this process's UDP socket bound to ``port`` (the stream's) now, before its first
    frame: Aravis sizes it only when that frame's first packet is read, and the burst of a frame overflows
    the system default before that (the first frame came incomplete). Returns what the kernel granted
    (bytes, as it reports it: twice the size asked, capped at ``net.core.rmem_max``), None if no such
    socket was found."""
    for name in os.listdir("/proc/self/fd"):
        try:
            sock = socket.socket(fileno=os.dup(int(name)))
        except OSError:
            continue
        with sock:
            try:
                if sock.type != socket.SOCK_DGRAM or sock.family != socket.AF_INET or sock.getsockname()[1] != port:
                    continue
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, size_bytes)
                return int(sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF))
            except OSError:
                continue
    return None


class AravisCamera:
    """One GigE Vision camera through Aravis, behind the camera driver protocol.

    ``device``: serial number, Aravis device id or IPv4 address (an address is opened directly, without
    discovery, so a camera on another subnet is reachable); ``name``: the camera's name in the rig.
    """

    def __init__(self, device: str, name: str, *, options: AravisOptions = AravisOptions(),
                 aravis: Any | None = None) -> None:
        if not device:
            raise ValueError(f"camera {name}: no device (serial, device id or IP address) given")
        self.device, self.name, self.options = device, name, options
        self._arv = aravis
        self._cam = self._stream = self._failed_stream = None
        self._settings = CaptureSettings()
        self._status = DriverStatus(camera=name, extra={
            "device": device, "incomplete": 0, "incomplete_before_start": 0, "empty_buffers": 0, "frame_id_gaps": 0,
            "device_skipped": 0, **{v: 0 for v in _STREAM_COUNTERS.values()}})
        self._stopped = False
        self._at_ns: int | None = None
        self._on_host_epoch = False
        self._last_system_ns = 0  # host arrival time (ns) of the newest frame leader seen
        self._action: ActionSupport | None = None  # what the device offers for a scheduled start (configure)

    # -- set-up -----------------------------------------------------------------------------------
    def open(self) -> None:
        """Connect to the device (ValueError naming the camera, the device and what was found)."""
        self._arv = self._arv or import_aravis()
        target = self.device
        if not _is_ipv4(self.device):
            found = discover(self._arv)
            match = [d for d in found if d.matches(self.device)]
            if not match:
                seen = ", ".join(f"{d.serial} at {d.address}" for d in found) or "none"
                raise ValueError(f"camera {self.name}: GigE Vision device {self.device!r} not found "
                                 f"(devices that answered discovery: {seen})")
            target = match[0].device_id
        try:
            self._cam = self._arv.Camera.new(target)
        except Exception as exc:  # GLib.GError
            raise ValueError(f"camera {self.name}: GigE Vision device {self.device} does not answer "
                             f"({_gerror_text(exc)})") from None
        if not self._cam.is_gv_device():
            raise ValueError(f"camera {self.name}: device {self.device} is not a GigE Vision camera")
        # the UDP socket, also as root (see StreamTuning): Aravis's packet socket takes every packet on the
        # interface until its filter is set, and one stray packet there sets the stream's frame count
        self._cam.gv_set_stream_options(self._arv.GvStreamOption.PACKET_SOCKET_DISABLED)
        ex = self._status.extra
        ex.update(serial=self._cam.get_device_serial_number() or "", model=self._cam.get_model_name() or "",
                  vendor=self._cam.get_vendor_name() or "", address=self._address(),
                  heartbeat_timeout_ms=self._heartbeat())
        self._status.state = "open"

    def _heartbeat(self) -> int:
        """Set the heartbeat timeout (:attr:`AravisOptions.heartbeat_timeout_ms`; the bootstrap register
        every GigE Vision device has) and return the value it took (ms)."""
        dev = self._cam.get_device()
        if self.options.heartbeat_timeout_ms is not None:
            self._set("heartbeat timeout", dev.write_register, HEARTBEAT_TIMEOUT_REGISTER,
                      self.options.heartbeat_timeout_ms)
        try:
            return int(dev.read_register(HEARTBEAT_TIMEOUT_REGISTER))
        except Exception as exc:  # GLib.GError
            raise ValueError(f"camera {self.name} ({self.device}): heartbeat timeout: {_gerror_text(exc)}") from None

    def _control_lost(self) -> str:
        """Why a camera may have stopped: a note when this host lost control of it ("" otherwise)."""
        try:
            lost = not self._cam.get_device().is_controller()
        except Exception:  # noqa: BLE001  (informative only)
            return ""
        timeout = self._status.extra.get("heartbeat_timeout_ms")
        return (f"; control of the camera lost: it heard no heartbeat from this host for {timeout} ms (a host "
                "too loaded, or another application took it)" if lost else "")

    def _address(self) -> str:
        try:
            return str(self._cam.get_device().get_device_address().to_string())
        except Exception:  # noqa: BLE001  (informative only)
            return self.device if _is_ipv4(self.device) else ""

    def _available(self, feature: str) -> bool:
        return bool(self._cam.is_feature_available(feature))

    def _set(self, what: str, setter, *args) -> None:
        try:
            setter(*args)
        except Exception as exc:  # GLib.GError from the device or GenICam
            raise ValueError(f"camera {self.name} ({self.device}): {what} {args}: {_gerror_text(exc)}") from None

    def configure(self, settings: CaptureSettings) -> None:
        """Free-run acquisition with the settings; what the camera took is read back into the status."""
        if self._cam is None:
            raise ValueError(f"camera {self.name}: configure() before open()")
        cam, opt = self._cam, self.options
        formats = list(cam.dup_available_pixel_formats_as_strings() or [])
        usable = [f for f in formats if f in SUPPORTED_FORMATS]
        if settings.pixel_format not in usable:
            raise ValueError(f"camera {self.name} ({self.device}): pixel format {settings.pixel_format!r} not "
                             f"offered; it offers {formats}, gaitcap converts {list(SUPPORTED_FORMATS)}")
        self._set("acquisition mode", cam.set_acquisition_mode, self._arv.AcquisitionMode.CONTINUOUS)
        self._set("triggers off", cam.clear_triggers)
        self._set("pixel format", cam.set_pixel_format_from_string, settings.pixel_format)
        if settings.size_px is not None:
            self._set("region", cam.set_region, 0, 0, int(settings.size_px[0]), int(settings.size_px[1]))
        if settings.exposure_us is not None:
            if cam.is_exposure_auto_available():
                self._set("exposure auto off", cam.set_exposure_time_auto, self._arv.Auto.OFF)
            self._set("exposure time", cam.set_exposure_time, float(settings.exposure_us))
        if opt.gain_db is not None:
            if cam.is_gain_auto_available():
                self._set("gain auto off", cam.set_gain_auto, self._arv.Auto.OFF)
            self._set("gain", cam.set_gain, float(opt.gain_db))
        self._set("frame rate", cam.set_frame_rate, float(settings.fps))
        if opt.packet_size_bytes is None:
            self._set("packet size negotiation", cam.gv_auto_packet_size)
        else:
            self._set("packet size", cam.gv_set_packet_size, int(opt.packet_size_bytes))
        self._set("packet delay", cam.gv_set_packet_delay, int(opt.packet_delay_ns))
        self._settings = settings
        self._action = action_support(cam)
        self._read_back()
        self._status.state = "configured"

    def _read_back(self) -> None:
        cam = self._cam
        region = cam.get_region()
        self._status.extra.update(
            pixel_format=cam.get_pixel_format_as_string(), size_px=[int(region.width), int(region.height)],
            fps_set=round(float(cam.get_frame_rate()), 3),
            exposure_us=round(float(cam.get_exposure_time()), 1) if cam.is_exposure_time_available() else None,
            gain_db=round(float(cam.get_gain()), 2) if cam.is_gain_available() else None,
            packet_size_bytes=int(cam.gv_get_packet_size()), packet_delay_ns=int(cam.gv_get_packet_delay()),
            ptp=self._ptp(), start_sync=START_SYNC, action_commands=self._action.describe(),
            trigger_sources=list(cam.dup_available_trigger_sources() or []))

    def _ptp(self) -> str:
        """Enable PTP where the device has it and return its state, or say the device has none."""
        dev = self._cam.get_device()
        for enable, state in _PTP_FEATURES:
            if self._available(enable):
                try:
                    dev.set_boolean_feature_value(enable, True)
                    return f"enabled ({enable}); state {dev.get_string_feature_value(state)}"
                except Exception as exc:  # noqa: BLE001  (reported, not assumed)
                    return f"{enable} present but not settable: {_gerror_text(exc)}"
        return "not supported by the device"

    # -- streaming --------------------------------------------------------------------------------
    def start(self, at_ns: int | None = None) -> None:
        """Start the stream now; frames stamped before ``at_ns`` (host epoch, ns) are discarded when the
        device clock is on the host's epoch."""
        if self._status.state != "configured":
            raise ValueError(f"camera {self.name}: start() in state {self._status.state}; configure() first")
        arv, opt = self._arv, self.options
        try:
            self._stream = self._cam.create_stream(None, None)
        except Exception as exc:
            raise ValueError(f"camera {self.name} ({self.device}): cannot open the stream: "
                             f"{_gerror_text(exc)}{self._control_lost()}") from None
        resend = arv.GvStreamPacketResend.ALWAYS if opt.packet_resend else arv.GvStreamPacketResend.NEVER
        self._stream.set_property("packet-resend", resend)
        payload = self._cam.get_payload()
        self._tune_stream(payload)
        for _ in range(opt.buffers):
            self._stream.push_buffer(arv.Buffer.new_allocate(payload))
        self._at_ns, self._stopped = at_ns, False
        self._start_acquisition(at_ns)
        self._status.state = "running"
        self._status.started_wall_s = max(at_ns or 0, time.time_ns()) / 1e9  # a start set in the past: now

    def _start_acquisition(self, at_ns: int | None) -> None:
        """A scheduled action command at ``at_ns`` where the device takes one, else a software start now."""
        if at_ns is None or self._action is None or not self._action.usable:
            self._cam.start_acquisition()
            return
        address = self.device if _is_ipv4(self.device) else self._status.extra["address"].rsplit(":", 1)[0]
        try:
            self._status.extra["start_sync"] = scheduled_start(self._cam, address, at_ns, self._action)
        except Exception as exc:  # GLib.GError from the device, OSError from the socket
            raise ValueError(f"camera {self.name} ({self.device}): scheduled start: {_gerror_text(exc)}") from None

    def _tune_stream(self, payload_bytes: int) -> None:
        """Socket receive buffer and frame retention of :class:`StreamTuning`, recorded in the status."""
        tuning, stream = self.options.tuning, self._stream
        asked = tuning.socket_buffer_bytes(payload_bytes)
        stream.set_property("socket-buffer", self._arv.GvStreamSocketBuffer.FIXED)
        stream.set_property("socket-buffer-size", asked)
        retention_us = tuning.frame_retention_us(self._settings.period_ns)
        stream.set_property("frame-retention", retention_us)
        cap = rmem_max_bytes()
        granted = _size_receive_buffer(int(stream.get_port()), asked)
        self._status.extra.update(socket_buffer_bytes=asked, socket_buffer_granted_bytes=granted, rmem_max_bytes=cap,
                                  frame_retention_ms=round(retention_us / 1000, 1))
        if cap is not None and cap < asked:
            log.warning("camera %s: stream socket buffer capped at net.core.rmem_max = %d bytes (%.1f frames; asked "
                        "%d): raise it (sysctl -w net.core.rmem_max=%d) where the receiver may lose packets", self.name,
                        cap, cap / payload_bytes, asked, asked)

    def frames(self) -> Iterator[Frame]:
        if self._stream is None:
            raise ValueError(f"camera {self.name}: frames() before start()")
        ids, offset, last = BlockIds(), None, None
        timeouts, stall_s = 0, self.options.stall_timeouts * self.options.frame_timeout_ms / 1000
        complete_at = time.monotonic()
        # the first frame may take longer: the start may lie ahead, and a camera takes a moment to start
        ahead_s = max(0.0, ((self._at_ns or 0) - time.time_ns()) / 1e9)
        first_limit = self.options.stall_timeouts * 2 + int(ahead_s * 1000 / self.options.frame_timeout_ms)
        seen = False
        try:
            while not self._stopped:
                buf = self._stream.timeout_pop_buffer(self.options.frame_timeout_ms * 1000)
                if buf is None:
                    timeouts += 1
                    if timeouts >= (self.options.stall_timeouts if seen else first_limit):
                        self._fail(f"no frame for {timeouts * self.options.frame_timeout_ms} ms (camera "
                                   f"unreachable, stopped or its stream blocked){self._control_lost()}")
                        return
                    continue
                timeouts, seen = 0, True
                frame, offset, whole = self._take(buf, ids, offset)
                if frame is None and whole:
                    complete_at = time.monotonic()  # whole, but before the synchronised start
                    continue
                if frame is None:
                    waited_s = time.monotonic() - complete_at
                    if waited_s > (stall_s if last is not None else 2 * stall_s + ahead_s):
                        self._fail(f"no complete frame for {waited_s:.0f} s, {self._status.extra['incomplete']} "
                                   "incomplete (packets lost on the link: check the MTU, packet size and delay)")
                        return
                    continue
                complete_at = time.monotonic()
                if last is not None and frame.frame_id > last.frame_id + 1:
                    self._status.extra["frame_id_gaps"] += 1
                self._status.count(frame)
                last = frame
                yield frame
                if self.options.max_frames is not None and self._status.frames >= self.options.max_frames:
                    return
        finally:
            self._refresh_counters()
            self._end()

    def _take(self, buf, ids: BlockIds, offset: int | None) -> tuple[Frame | None, int | None, bool]:
        """Frame of one popped buffer (None: incomplete or before the start), the frame id offset and
        whether the buffer held a whole frame."""
        try:
            status = buf.get_status()
            if status != self._arv.BufferStatus.SUCCESS:
                # not counted into the block ids: a buffer that lost its leader may carry id 0; the next
                # whole frame shows the gap
                self._count_unfinished(buf, status)
                return None, offset, False
            self._last_system_ns = max(self._last_system_ns, int(buf.get_system_timestamp()))
            ts = int(buf.get_timestamp())
            count = ids.next(int(buf.get_frame_id()))
            image = self._image(buf)
        finally:
            self._stream.push_buffer(buf)
        period = self._settings.period_ns
        if offset is None:
            on_host_epoch = self._on_host_epoch = abs(ts - time.time_ns()) < CLOCK_ON_HOST_EPOCH_NS
            self._status.extra["device_clock"] = "host epoch" if on_host_epoch else "own epoch (frame ids from the first frame)"
            if on_host_epoch and self._at_ns is not None:
                if ts < self._at_ns - period // 2:
                    return None, None, True  # before the synchronised start
                offset = int(round((ts - self._at_ns) / period)) - count
            else:
                offset = -count
        frame_id = offset + count
        prev = self._status.last_timestamp_ns
        gap = frame_id - (self._status.last_frame_id if self._status.last_frame_id is not None else frame_id)
        jump = prev is not None and is_ptp_jump(ts - prev, period * max(gap, 1))
        late = (ts - self._at_ns) / period - frame_id if self._on_host_epoch and self._at_ns is not None else 0.0
        if late > 1.5:  # periods passed on the device clock without a frame (its block ids went on by 1)
            skipped = round(late)
            offset, frame_id = offset + skipped, frame_id + skipped
            self._status.extra["device_skipped"] += skipped
        if self._status.frames % 30 == 0:
            self._refresh_counters()
        return Frame(camera=self.name, image=image, timestamp_ns=ts, frame_id=frame_id, ptp_jump=jump), offset, True

    def _count_unfinished(self, buf, status) -> None:
        """Count a buffer that holds no whole frame: ``empty_buffers`` (CLEARED: Aravis never filled it, no
        frame), ``incomplete_before_start`` (its packets came before the synchronised start: not a trial
        frame) or ``incomplete``."""
        ex = self._status.extra
        if status == self._arv.BufferStatus.CLEARED:
            ex["empty_buffers"] += 1
            log.info("camera %s: an empty stream buffer (no frame in it)", self.name)
            return
        before = self._before_start(int(buf.get_system_timestamp()))
        ex["incomplete_before_start" if before else "incomplete"] += 1
        log.info("camera %s: incomplete frame (%s)%s", self.name, status.value_nick,
                 " before the synchronised start" if before else "")

    def _before_start(self, system_ns: int) -> bool:
        """Whether an unfinished frame came before the synchronised start, judged on the host clock: its
        leader's arrival time where Aravis stamped it for this frame (later than any frame seen before;
        a buffer whose leader was lost keeps an older stamp), else the time it is handed over (its
        packets all came before). A frame within half a period of the start counts as a trial frame."""
        if self._at_ns is None:
            return False
        limit = self._at_ns - self._settings.period_ns // 2
        if system_ns > self._last_system_ns:
            self._last_system_ns = system_ns
            return system_ns < limit
        return time.time_ns() < limit

    def _image(self, buf) -> np.ndarray:
        w, h = int(buf.get_image_width()), int(buf.get_image_height())
        data = np.frombuffer(buf.get_data(), dtype=np.uint8)
        fmt = self._settings.pixel_format
        channels = 3 if fmt in ("RGB8", "BGR8") else 1
        raw = data[: w * h * channels].reshape((h, w, channels) if channels == 3 else (h, w))
        return to_bgr(raw.copy(), fmt)

    def _refresh_counters(self) -> None:
        if self._stream is None:
            return
        stream, ex = self._stream, self._status.extra
        names = {stream.get_info_name(i): i for i in range(stream.get_n_infos())}
        for info, key in _STREAM_COUNTERS.items():
            if info in names:
                ex[key] = int(stream.get_info_uint64(names[info]))

    def _fail(self, message: str) -> None:
        self._status.state = "error"
        self._status.error = f"camera {self.name} ({self.device}): {message}"
        log.error(self._status.error)

    def _end(self) -> None:
        if self._cam is not None and self._stream is not None and self._status.state != "error":
            try:
                self._cam.stop_acquisition()
            except Exception as exc:  # noqa: BLE001  (logged; the stream is dropped all the same)
                log.warning("camera %s: stop acquisition: %s", self.name, _gerror_text(exc))
        if self._status.state == "error" and self._stream is not None:
            # a camera that failed is not told to stop (that times out, about 7 s), and its stream is kept
            # until close(): disposing of it waits about 5 s for its thread, holding the interpreter
            self._failed_stream = self._stream
        self._stream = None
        if self._status.state == "running":
            self._status.state = "stopped"

    def stop(self) -> None:
        self._stopped = True

    def close(self) -> None:
        self._stopped = True
        self._end()
        self._cam = self._failed_stream = None
        self._status.state = "closed"

    def status(self) -> DriverStatus:
        return self._status
