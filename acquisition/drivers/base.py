"""The camera driver protocol shared by FLIR, simulated and video drivers.

Life cycle: ``open()`` -> ``configure(settings)`` -> ``start(at_ns)`` -> iterate ``frames()`` ->
``stop()``; ``status()`` may be called at any time (from another thread too). A driver yields
:class:`Frame` objects carrying the image, the camera timestamp in ns and a frame id counted from the
synchronised start (0, 1, 2, ...; a gap in the ids is a dropped frame).
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np


@dataclass(frozen=True)
class CaptureSettings:
    """What every driver is configured with.

    Attributes:
        fps: frame rate in frames/s.
        exposure_us: fixed exposure in microseconds (None: driver default / not applicable).
        size_px: (width, height) of the delivered image in px (None: native size).
        pixel_format: sensor pixel format for drivers that have one (e.g. "BayerRG8", "Mono8").
    """

    fps: float = 30.0
    exposure_us: float | None = 15000.0
    size_px: tuple[int, int] | None = None
    pixel_format: str = "BayerRG8"

    def __post_init__(self) -> None:
        if not (self.fps > 0):
            raise ValueError(f"fps: must be > 0, got {self.fps}")
        if self.exposure_us is not None and not (0 < self.exposure_us < 1e6 / self.fps):
            raise ValueError(
                f"exposure_us: {self.exposure_us} us does not fit in one frame period at {self.fps} fps"
            )
        if self.size_px is not None and (len(self.size_px) != 2 or min(self.size_px) <= 0):
            raise ValueError(f"size_px: expected (width, height) > 0, got {self.size_px}")

    @property
    def period_ns(self) -> int:
        return int(round(1e9 / self.fps))


@dataclass(frozen=True, eq=False)
class Frame:
    """One image from one camera.

    Attributes:
        camera: camera name (as in the calibration).
        image: (H, W, 3) uint8 BGR (or (H, W) for mono).
        timestamp_ns: camera timestamp in ns (PTP / synthetic clock, same epoch for all cameras).
        frame_id: frame counter from the synchronised start (0-based).
        ptp_jump: True when the interval to the previous frame differs from the period by > 10x.
        jpeg: the image already JPEG-encoded (drivers that deliver compressed frames; ``image`` may then
            be None).
    """

    camera: str
    image: np.ndarray | None
    timestamp_ns: int
    frame_id: int
    ptp_jump: bool = False
    jpeg: bytes | None = None


@dataclass
class DriverStatus:
    """Live counters of one driver (mutable, updated by the driver as frames arrive)."""

    camera: str
    state: str = "closed"  # closed | open | configured | running | stopped | error
    frames: int = 0
    drops: int = 0
    last_timestamp_ns: int | None = None
    last_frame_id: int | None = None
    ptp_jumps: int = 0
    error: str | None = None
    started_wall_s: float | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def healthy(self) -> bool:
        return self.state in ("open", "configured", "running") and self.error is None

    def fps(self, now_s: float | None = None) -> float:
        """Mean delivered frame rate since start in frames/s (0 before the first frame)."""
        if self.started_wall_s is None or self.frames == 0:
            return 0.0
        elapsed = (time.time() if now_s is None else now_s) - self.started_wall_s
        return self.frames / elapsed if elapsed > 0 else 0.0

    def to_dict(self) -> dict[str, Any]:
        return {
            "camera": self.camera,
            "state": self.state,
            "health": "ok" if self.healthy else (self.state if self.error is None else "error"),
            "fps": round(self.fps(), 3),
            "frames": self.frames,
            "drops": self.drops,
            "last_timestamp_ns": self.last_timestamp_ns,
            "last_frame_id": self.last_frame_id,
            "ptp_jumps": self.ptp_jumps,
            "error": self.error,
            **self.extra,
        }

    def count(self, frame: Frame) -> None:
        """Update the counters for a delivered frame (drops from frame-id gaps)."""
        if self.last_frame_id is not None and frame.frame_id > self.last_frame_id + 1:
            self.drops += frame.frame_id - self.last_frame_id - 1
        self.frames += 1
        self.last_frame_id = frame.frame_id
        self.last_timestamp_ns = frame.timestamp_ns
        self.ptp_jumps += int(frame.ptp_jump)


@runtime_checkable
class CameraDriver(Protocol):
    """A camera (or a simulated / recorded one)."""

    name: str

    def open(self) -> None: ...

    def configure(self, settings: CaptureSettings) -> None: ...

    def start(self, at_ns: int | None = None) -> None:
        """Start acquiring at ``at_ns`` (camera clock, ns; None: now)."""

    def frames(self) -> Iterator[Frame]:
        """Yield frames until stopped or the source ends."""

    def stop(self) -> None: ...

    def status(self) -> DriverStatus: ...


def is_ptp_jump(interval_ns: int, period_ns: int, factor: float = 10.0) -> bool:
    """The lab's PTP jump flag: an interval that differs from the period by more than ``factor`` x.

    Negative intervals (the clock stepped back) always count as a jump.
    """
    if interval_ns <= 0:
        return True
    return interval_ns > factor * period_ns or interval_ns * factor < period_ns


def wait_until_ns(at_ns: int, clock=time.time_ns) -> None:
    """Sleep until ``clock()`` reaches ``at_ns`` (ns)."""
    while True:
        remaining = at_ns - clock()
        if remaining <= 0:
            return
        time.sleep(min(remaining / 1e9, 0.05))
