"""Typed camera-source configs: each builds the opened and configured drivers of one host.

``SimulatedSource`` (synthetic world), ``VideoSource`` (files / webcams), ``FlirSource`` (PySpin),
``AravisSource`` (GigE Vision cameras through Aravis).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from gaitcap.acquisition.drivers.base import CameraDriver, CaptureSettings
from gaitcap.acquisition.drivers.simulated import SimTrialSpec, parse_faults, simulated_rig


@dataclass(frozen=True)
class SimulatedSource:
    """Simulated cameras of a synthetic trial (all, or the named subset)."""

    spec: SimTrialSpec = SimTrialSpec()
    cameras: list[str] | None = None
    size_px: tuple[int, int] = (640, 480)
    fps: float = 30.0
    drops: tuple[str, ...] = ()
    stops: tuple[str, ...] = ()
    realtime: bool = True
    max_frames: int | None = None
    loop: bool = False  # play the walk again and again (frame ids counting on)

    def build(self) -> list[CameraDriver]:
        trial = self.spec.make()
        return simulated_rig(trial, size_px=self.size_px, fps=self.fps, realtime=self.realtime,
                             faults=parse_faults(list(self.drops), list(self.stops)), cameras=self.cameras,
                             max_frames=self.max_frames, loop=self.loop)


@dataclass(frozen=True)
class VideoSource:
    """Video files (camera named after the file stem) and webcams (``webcam<index>``)."""

    files: tuple[str, ...] = ()
    webcams: tuple[int, ...] = ()
    fps: float = 30.0
    realtime: bool = True

    def build(self) -> list[CameraDriver]:
        from gaitcap.acquisition.drivers.video import VideoCamera, WebcamCamera

        if not self.files and not self.webcams:
            raise ValueError("video source: give --video FILE and/or --webcam INDEX")
        drivers: list[CameraDriver] = [VideoCamera(Path(f), realtime=self.realtime) for f in self.files]
        drivers += [WebcamCamera(i) for i in self.webcams]
        for d in drivers:
            d.open()
            d.configure(CaptureSettings(fps=self.fps, exposure_us=None))
        return drivers


@dataclass(frozen=True)
class FlirSource:
    """FLIR Spinnaker GigE cameras by serial number (PTP-synchronised, scheduled start)."""

    serials: tuple[str, ...] = ()
    names: tuple[str, ...] = ()
    fps: float = 30.0
    exposure_us: float = 15000.0
    pixel_format: str = "BayerRG8"
    packet_size: int = 9000
    packet_delay: int = 4000
    trigger_source: str = "Action0"

    def build(self) -> list[CameraDriver]:
        from gaitcap.acquisition.drivers.flir import FlirSystem, GigESettings

        if not self.serials:
            raise ValueError("flir source: give --serials S1,S2,...")
        if self.names and len(self.names) != len(self.serials):
            raise ValueError(f"flir source: {len(self.names)} names for {len(self.serials)} serials")
        system = FlirSystem()
        cams = system.cameras(list(self.serials), names=list(self.names) or None,
                              gige=GigESettings(packet_size=self.packet_size, packet_delay=self.packet_delay,
                                                trigger_source=self.trigger_source))
        settings = CaptureSettings(fps=self.fps, exposure_us=self.exposure_us, pixel_format=self.pixel_format)
        for cam in cams:
            cam.open()
            cam.configure(settings)
        system.wait_ptp_locked(cams)
        return cams


@dataclass(frozen=True)
class AravisSource:
    """GigE Vision cameras through Aravis (FLIR and others, no vendor SDK) by serial number, Aravis device
    id or IPv4 address; names default to the devices. Packet size in bytes, packet delay in ns, gain in dB."""

    devices: tuple[str, ...] = ()
    names: tuple[str, ...] = ()
    fps: float = 30.0
    exposure_us: float = 15000.0
    pixel_format: str = "BayerRG8"
    packet_size_bytes: int | None = 1400
    packet_delay_ns: int = 0
    gain_db: float | None = None
    max_frames: int | None = None

    def build(self) -> list[CameraDriver]:
        from gaitcap.acquisition.drivers.aravis import AravisCamera, AravisOptions

        if not self.devices:
            raise ValueError("aravis source: give --devices SERIAL_OR_ADDRESS,...")
        if self.names and len(self.names) != len(self.devices):
            raise ValueError(f"aravis source: {len(self.names)} names for {len(self.devices)} devices")
        options = AravisOptions(packet_size_bytes=self.packet_size_bytes, packet_delay_ns=self.packet_delay_ns,
                                gain_db=self.gain_db, max_frames=self.max_frames)
        settings = CaptureSettings(fps=self.fps, exposure_us=self.exposure_us, pixel_format=self.pixel_format)
        cams = [AravisCamera(d, n, options=options)
                for d, n in zip(self.devices, self.names or self.devices, strict=True)]
        for cam in cams:
            cam.open()
            cam.configure(settings)
        return cams
