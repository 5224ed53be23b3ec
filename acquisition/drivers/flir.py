"""FLIR (Teledyne) Spinnaker GigE cameras through PySpin, synchronised the way the lab's rig is.

Set-up per camera (:meth:`FlirCamera.configure`): continuous acquisition, fixed exposure (auto off),
fixed frame rate, pixel format, jumbo packets and inter-packet delay, oldest-first stream buffers,
IEEE1588 PTP on, and acquisition start triggered by action command 0 (device/group key and mask).
:meth:`FlirSystem.wait_ptp_locked` waits until one camera is PTP master (or an external grandmaster
leads) and all others are slaves. The synchronised start: every camera is armed (``BeginAcquisition``)
and ONE scheduled action command is sent on every interface for a PTP time about 250 ms ahead; after it
the cameras free-run. Frames carry the camera's PTP timestamp (ns) and a frame id counted from the
first frame; frame-id gaps are drops, incomplete images are dropped and counted, an interval that
differs from the period by more than 10x is flagged as a PTP jump.

PySpin is not on the package index (it ships with FLIR's Spinnaker SDK), so it is imported lazily and
a missing install gives a clear message. Tests run against a fake PySpin module.
"""

from __future__ import annotations

import importlib
import logging
import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from gaitcap.acquisition.drivers.base import CaptureSettings, DriverStatus, Frame, is_ptp_jump

log = logging.getLogger(__name__)

# Spinnaker pixel formats -> OpenCV demosaicing code. OpenCV names a Bayer pattern by the 2x2 block one
# pixel down and right, so Spinnaker's BayerRG (RGGB from the top-left) is OpenCV's BayerBG.
_BAYER_TO_CV = {"BayerRG8": "COLOR_BayerBG2BGR", "BayerBG8": "COLOR_BayerRG2BGR",
                "BayerGR8": "COLOR_BayerGB2BGR", "BayerGB8": "COLOR_BayerGR2BGR"}
_DIRECT_FORMATS = ("Mono8", "BGR8", "RGB8")
PTP_LOCKED = ("Master", "Slave")
PTP_STATES = ("Initializing", "Faulty", "Disabled", "Listening", "PreMaster", "Master", "Passive",
              "Uncalibrated", "Slave")


class PySpinMissing(ValueError):
    """PySpin (FLIR Spinnaker SDK Python bindings) is not installed."""


def import_pyspin():
    """Import PySpin or raise :class:`PySpinMissing` with installation instructions."""
    try:
        return importlib.import_module("PySpin")
    except ImportError as exc:
        raise PySpinMissing(
            "the FLIR driver needs PySpin, which is not on PyPI: install FLIR's Spinnaker SDK and its "
            "Python wheel (spinnaker_python-<version>-cp311-...whl from Teledyne FLIR's download site) "
            f"into this environment ({exc})"
        ) from None


def to_bgr(raw: np.ndarray, pixel_format: str) -> np.ndarray:
    """A raw Spinnaker image (H, W) or (H, W, 3) -> (H, W, 3) uint8 BGR (Bayer demosaiced)."""
    import cv2

    if pixel_format in _BAYER_TO_CV:
        return cv2.cvtColor(raw, getattr(cv2, _BAYER_TO_CV[pixel_format]))
    if pixel_format == "Mono8":
        return cv2.cvtColor(raw, cv2.COLOR_GRAY2BGR)
    if pixel_format == "RGB8":
        return cv2.cvtColor(raw, cv2.COLOR_RGB2BGR)
    if pixel_format == "BGR8":
        return raw
    raise ValueError(f"pixel format {pixel_format!r} not supported; use one of "
                     f"{sorted(_BAYER_TO_CV) + list(_DIRECT_FORMATS)}")


@dataclass(frozen=True)
class GigESettings:
    """GigE Vision transport and action-command settings.

    Attributes:
        packet_size: stream packet size in bytes (9000 = jumbo frames; the NIC MTU must allow it).
        packet_delay: inter-packet delay (GevSCPD, timestamp ticks) so 10 cameras share one link.
        action_device_key, action_group_key, action_group_mask: action command addressing.
        start_delay_s: how far ahead the scheduled action command is set (the lab: ~250 ms).
        trigger_source: "Action0" (scheduled action command) or a hardware line (e.g. "Line0": an
            external pulse starts every camera; no action command is sent).
        frame_timeout_ms: GetNextImage timeout; ``stall_timeouts`` in a row = the camera is gone.
    """

    packet_size: int = 9000
    packet_delay: int = 4000
    action_device_key: int = 0x1
    action_group_key: int = 0x1
    action_group_mask: int = 0x1
    start_delay_s: float = 0.25
    trigger_source: str = "Action0"
    frame_timeout_ms: int = 1000
    stall_timeouts: int = 5


class FlirCamera:
    """One Spinnaker camera behind the camera driver protocol (create through :class:`FlirSystem`)."""

    def __init__(self, system: FlirSystem, cam: Any, serial: str, name: str, gige: GigESettings) -> None:
        self.system, self.cam, self.serial, self.name, self.gige = system, cam, serial, name, gige
        self.PySpin = system.PySpin
        self._settings = CaptureSettings()
        self._status = DriverStatus(camera=name, extra={"serial": serial, "incomplete": 0})
        self._stopped = False
        self._armed = False

    def _enum(self, prefix: str, value: str) -> Any:
        try:
            return getattr(self.PySpin, f"{prefix}_{value}")
        except AttributeError:
            raise ValueError(f"camera {self.name} ({self.serial}): {prefix} {value!r} unknown to PySpin") from None

    def open(self) -> None:
        self.cam.Init()
        self._status.state = "open"

    def configure(self, settings: CaptureSettings) -> None:
        """Exposure, frame rate, pixel format, packets, PTP, action-command trigger (order matters)."""
        if settings.pixel_format not in _BAYER_TO_CV and settings.pixel_format not in _DIRECT_FORMATS:
            to_bgr(np.zeros((2, 2), np.uint8), settings.pixel_format)  # raises naming the formats
        cam, g = self.cam, self.gige
        cam.AcquisitionMode.SetValue(self._enum("AcquisitionMode", "Continuous"))
        cam.PixelFormat.SetValue(self._enum("PixelFormat", settings.pixel_format))
        cam.ExposureAuto.SetValue(self._enum("ExposureAuto", "Off"))
        if settings.exposure_us is not None:
            cam.ExposureTime.SetValue(float(settings.exposure_us))
        cam.AcquisitionFrameRateEnable.SetValue(True)
        cam.AcquisitionFrameRate.SetValue(float(settings.fps))
        cam.GevSCPSPacketSize.SetValue(int(g.packet_size))
        cam.GevSCPD.SetValue(int(g.packet_delay))
        cam.TLStream.StreamBufferHandlingMode.SetValue(self._enum("StreamBufferHandlingMode", "OldestFirst"))
        cam.GevIEEE1588.SetValue(True)
        cam.TriggerMode.SetValue(self._enum("TriggerMode", "Off"))
        cam.TriggerSelector.SetValue(self._enum("TriggerSelector", "AcquisitionStart"))
        cam.TriggerSource.SetValue(self._enum("TriggerSource", g.trigger_source))
        cam.ActionSelector.SetValue(0)
        cam.ActionDeviceKey.SetValue(int(g.action_device_key))
        cam.ActionGroupKey.SetValue(int(g.action_group_key))
        cam.ActionGroupMask.SetValue(int(g.action_group_mask))
        cam.TriggerMode.SetValue(self._enum("TriggerMode", "On"))
        self._settings = settings
        self._status.state = "configured"

    def ptp_state(self) -> str:
        value = self.cam.GevIEEE1588Status.GetValue()
        for name in PTP_STATES:
            if getattr(self.PySpin, f"GevIEEE1588Status_{name}", object()) == value:
                return name
        return str(value)

    def latch_timestamp_ns(self) -> int:
        """The camera's PTP clock now (ns)."""
        self.cam.TimestampLatch.Execute()
        return int(self.cam.TimestampLatchValue.GetValue())

    def start(self, at_ns: int | None = None) -> None:
        """Arm the camera; when every camera of the system is armed, the scheduled start is sent
        (``at_ns`` in host wall-clock ns, mapped onto the cameras' PTP clock)."""
        if self._status.state != "configured":
            raise ValueError(f"camera {self.name}: start() in state {self._status.state}; configure() first")
        self.cam.BeginAcquisition()
        self._armed, self._stopped = True, False
        self._status.state = "running"
        self._status.started_wall_s = (at_ns or time.time_ns()) / 1e9
        self.system._armed(self, at_ns)

    def frames(self) -> Iterator[Frame]:
        period = self._settings.period_ns
        first_id = last_id = last_ts = None
        timeouts = 0
        try:
            while not self._stopped:
                try:
                    image = self.cam.GetNextImage(self.gige.frame_timeout_ms)
                except self.PySpin.SpinnakerException as exc:
                    timeouts += 1
                    if timeouts >= self.gige.stall_timeouts:
                        self._fail(f"no frame for {timeouts * self.gige.frame_timeout_ms} ms ({exc})")
                        return
                    continue
                timeouts = 0
                try:
                    if image.IsIncomplete():
                        self._status.extra["incomplete"] += 1
                        continue
                    cam_id, ts = int(image.GetFrameID()), int(image.GetTimeStamp())
                    raw = np.array(image.GetNDArray(), copy=True)
                finally:
                    image.Release()
                first_id = cam_id if first_id is None else first_id
                frame_id = cam_id - first_id
                jump = last_ts is not None and is_ptp_jump(ts - last_ts, period * max(frame_id - last_id, 1))
                frame = Frame(camera=self.name, image=to_bgr(raw, self._settings.pixel_format),
                              timestamp_ns=ts, frame_id=frame_id, ptp_jump=jump)
                self._status.count(frame)
                last_id, last_ts = frame_id, ts
                yield frame
        finally:
            self._end_acquisition()

    def _fail(self, message: str) -> None:
        self._status.state = "error"
        self._status.error = f"camera {self.name} ({self.serial}): {message}"
        log.error(self._status.error)

    def _end_acquisition(self) -> None:
        if self._armed:
            self._armed = False
            try:
                self.cam.EndAcquisition()
            except self.PySpin.SpinnakerException as exc:
                log.warning("camera %s: EndAcquisition: %s", self.name, exc)
        if self._status.state == "running":
            self._status.state = "stopped"

    def stop(self) -> None:
        self._stopped = True

    def close(self) -> None:
        self._end_acquisition()
        self.cam.DeInit()
        self._status.state = "closed"

    def status(self) -> DriverStatus:
        return self._status


class FlirSystem:
    """The Spinnaker system: discovery by serial, PTP lock, the scheduled synchronised start."""

    def __init__(self, pyspin: Any | None = None) -> None:
        self.PySpin = pyspin if pyspin is not None else import_pyspin()
        self.system = self.PySpin.System.GetInstance()
        self._cam_list = self.system.GetCameras()
        self._cameras: list[FlirCamera] = []
        self._pending: dict[str, int | None] = {}
        self.action_time_ns: int | None = None

    def serials(self) -> list[str]:
        """Serial numbers of the cameras found on every interface."""
        return [str(self._cam_list.GetByIndex(i).TLDevice.DeviceSerialNumber.GetValue())
                for i in range(self._cam_list.GetSize())]

    def cameras(self, serials: list[str], *, names: list[str] | None = None,
                gige: GigESettings = GigESettings()) -> list[FlirCamera]:
        """Drivers for ``serials`` (names default to the serials); ValueError naming missing serials."""
        found = self.serials()
        missing = [s for s in serials if s not in found]
        if missing:
            raise ValueError(f"FLIR cameras not found: serials {missing}; found {found}")
        names = names or list(serials)
        cams = [FlirCamera(self, self._cam_list.GetBySerial(s), s, n, gige) for s, n in zip(serials, names, strict=True)]
        self._cameras.extend(cams)
        return cams

    def wait_ptp_locked(self, cams: list[FlirCamera], *, timeout_s: float = 30.0, poll_s: float = 0.5,
                        clock=time.monotonic, sleep=time.sleep) -> dict[str, str]:
        """Wait until every camera is PTP Master or Slave with at most one Master; {name: state}."""
        end = clock() + timeout_s
        while True:
            states = {c.name: c.ptp_state() for c in cams}
            masters = [n for n, s in states.items() if s == "Master"]
            if all(s in PTP_LOCKED for s in states.values()) and len(masters) <= 1:
                log.info("PTP locked: %s", states)
                return states
            if clock() >= end:
                raise ValueError(f"PTP not locked after {timeout_s} s: {states} (need one Master, others Slave)")
            sleep(poll_s)

    def _armed(self, cam: FlirCamera, at_ns: int | None) -> None:
        self._pending[cam.name] = at_ns
        if cam.gige.trigger_source != "Action0":
            log.info("camera %s armed, waiting for the hardware trigger on %s", cam.name, cam.gige.trigger_source)
            return
        if len(self._pending) == len(self._cameras):
            wanted = [v for v in self._pending.values() if v is not None]
            self.fire_action(at_wall_ns=min(wanted) if wanted else None)
            self._pending.clear()

    def fire_action(self, *, at_wall_ns: int | None = None) -> int:
        """Send ONE scheduled action command to all cameras; returns the PTP time (ns) it fires at."""
        if not self._cameras:
            raise ValueError("no FLIR cameras to start")
        gige = self._cameras[0].gige
        now_ptp = self._cameras[0].latch_timestamp_ns()
        ahead_ns = int(gige.start_delay_s * 1e9) if at_wall_ns is None else max(at_wall_ns - time.time_ns(), 0)
        action_ns = now_ptp + max(ahead_ns, int(0.05e9))
        ifaces = self.system.GetInterfaces()
        try:
            for i in range(ifaces.GetSize()):
                tl = ifaces.GetByIndex(i).TLInterface
                tl.GevActionDeviceKey.SetValue(gige.action_device_key)
                tl.GevActionGroupKey.SetValue(gige.action_group_key)
                tl.GevActionGroupMask.SetValue(gige.action_group_mask)
                tl.GevActionTime.SetValue(action_ns)
                tl.ActionCommand.Execute()
        finally:
            ifaces.Clear()
        self.action_time_ns = action_ns
        log.info("scheduled action command at PTP %d ns (%.0f ms ahead)", action_ns, (action_ns - now_ptp) / 1e6)
        return action_ns

    def release(self) -> None:
        for cam in self._cameras:
            if cam.status().state != "closed":
                cam.close()
        self._cameras.clear()
        self._cam_list.Clear()
        self.system.ReleaseInstance()
