"""Video files and webcams through OpenCV, behind the camera driver protocol.

A video file plays as one camera named after the file stem: frame ``i`` gets
``timestamp_ns = start_ns + i * period`` (period from the file's frame rate, else the configured one)
and frame id ``i``. With ``realtime`` the frames are paced on the wall clock (to feed the live pipeline
like a real rig). A webcam stamps frames with the host clock when they are grabbed.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterator
from pathlib import Path

from gaitcap.acquisition.drivers.base import CaptureSettings, DriverStatus, Frame, is_ptp_jump, wait_until_ns

log = logging.getLogger(__name__)


class _OpenCVCamera:
    """Shared life cycle of OpenCV sources."""

    name: str

    def __init__(self) -> None:
        self._cap = None
        self._settings = CaptureSettings(exposure_us=None)
        self._status = DriverStatus(camera=self.name)
        self._start_ns: int | None = None
        self._stopped = False

    def _open_capture(self):  # pragma: no cover - overridden
        raise NotImplementedError

    def open(self) -> None:
        self._cap = self._open_capture()
        self._status.state = "open"

    def configure(self, settings: CaptureSettings) -> None:
        if self._cap is None:
            raise ValueError(f"camera {self.name}: configure() before open()")
        self._settings = settings
        self._status.state = "configured"

    def start(self, at_ns: int | None = None) -> None:
        if self._cap is None:
            raise ValueError(f"camera {self.name}: start() before open()")
        self._start_ns = time.time_ns() if at_ns is None else int(at_ns)
        self._stopped = False
        self._status.state = "running"
        self._status.started_wall_s = self._start_ns / 1e9

    def stop(self) -> None:
        self._stopped = True
        if self._status.state == "running":
            self._status.state = "stopped"

    def close(self) -> None:
        if self._cap is not None:
            self._cap.release()
            self._cap = None
        self._status.state = "closed"

    def status(self) -> DriverStatus:
        return self._status


class VideoCamera(_OpenCVCamera):
    """One video file as one camera (name: the file stem)."""

    def __init__(self, path: Path, *, realtime: bool = True, name: str | None = None) -> None:
        self.path = Path(path)
        if not self.path.is_file():
            raise FileNotFoundError(f"video {self.path} not found")
        self.name = name or self.path.stem
        self.realtime = realtime
        super().__init__()

    def _open_capture(self):
        import cv2

        cap = cv2.VideoCapture(str(self.path))
        if not cap.isOpened():
            raise ValueError(f"video {self.path}: OpenCV cannot open it")
        return cap

    @property
    def file_fps(self) -> float | None:
        import cv2

        fps = float(self._cap.get(cv2.CAP_PROP_FPS)) if self._cap is not None else 0.0
        return fps if fps > 0 else None

    @property
    def frame_count(self) -> int | None:
        """Frames in the file as its header says (None when unknown)."""
        import cv2

        n = int(self._cap.get(cv2.CAP_PROP_FRAME_COUNT)) if self._cap is not None else 0
        return n if n > 0 else None

    def frames(self) -> Iterator[Frame]:
        if self._start_ns is None:
            raise ValueError(f"camera {self.name}: frames() before start()")
        period = int(round(1e9 / (self.file_fps or self._settings.fps)))
        frame_id = 0
        while not self._stopped:
            ok, image = self._cap.read()
            if not ok:
                break
            ts = self._start_ns + frame_id * period
            if self.realtime:
                wait_until_ns(ts)
            frame = Frame(camera=self.name, image=image, timestamp_ns=ts, frame_id=frame_id)
            self._status.count(frame)
            yield frame
            frame_id += 1
        if self._status.state == "running":
            self._status.state = "stopped"


class WebcamCamera(_OpenCVCamera):
    """A webcam (OpenCV device index) stamped with the host clock at grab time."""

    def __init__(self, index: int, *, name: str | None = None) -> None:
        self.index = int(index)
        self.name = name or f"webcam{self.index}"
        super().__init__()

    def _open_capture(self):
        import cv2

        cap = cv2.VideoCapture(self.index)
        if not cap.isOpened():
            raise ValueError(f"webcam {self.index}: cannot open it")
        return cap

    def configure(self, settings: CaptureSettings) -> None:
        import cv2

        super().configure(settings)
        self._cap.set(cv2.CAP_PROP_FPS, settings.fps)
        if settings.size_px is not None:
            self._cap.set(cv2.CAP_PROP_FRAME_WIDTH, settings.size_px[0])
            self._cap.set(cv2.CAP_PROP_FRAME_HEIGHT, settings.size_px[1])

    def frames(self) -> Iterator[Frame]:
        wait_until_ns(self._start_ns or 0)
        frame_id, last = 0, None
        while not self._stopped:
            ok, image = self._cap.read()
            if not ok:
                self._status.state, self._status.error = "error", f"webcam {self.index}: read failed"
                return
            ts = time.time_ns()
            jump = last is not None and is_ptp_jump(ts - last, self._settings.period_ns)
            frame = Frame(camera=self.name, image=image, timestamp_ns=ts, frame_id=frame_id, ptp_jump=jump)
            self._status.count(frame)
            yield frame
            frame_id, last = frame_id + 1, ts
