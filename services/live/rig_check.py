"""Is the rig fit to record? Checked before Start (and shown on the page).

Problems, in plain words: no camera delivering images; cameras the calibration needs that are missing or
not working; cameras far below the sync criteria's frame rate (below ``start_fraction`` of
:attr:`QualityCriteria.min_fps`, i.e. 21 fps at the default 28 fps). Start is refused when there is any,
unless the clinician confirms (the override is audited and becomes a warning of the trial); with no
camera delivering images (:data:`NO_CAMERA`) there is nothing to record, and no confirmation starts it.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

from gaitcap.services.live.protocols import CameraHealth
from gaitcap.services.processing.quality import QualityCriteria


def _min_fps() -> float:
    """The sync criteria's frame rate (Hz) for the live cameras: 28 for 30 Hz cameras, or GAITCAP_MIN_FPS."""
    return float(os.environ.get("GAITCAP_MIN_FPS", QualityCriteria().min_fps_at(30.0)))


@dataclass(frozen=True)
class RigCriteria:
    """min_fps: the sync criteria's frame rate (Hz); start_fraction: Start is refused below this share of
    it (far below, not merely below: a camera a little slow gives a warning on the trial instead)."""

    min_fps: float = field(default_factory=_min_fps)
    start_fraction: float = 0.75

    def __post_init__(self) -> None:
        if self.min_fps <= 0 or not 0 < self.start_fraction <= 1:
            raise ValueError(f"min_fps > 0 and start_fraction in (0, 1] needed, got {self.min_fps}, "
                             f"{self.start_fraction}")

    @property
    def start_min_fps(self) -> float:
        return self.min_fps * self.start_fraction


NO_CAMERA = "no camera is delivering images"


def _names(items: list[str], most: int = 4) -> str:
    return ", ".join(items[:most]) + (f" and {len(items) - most} more" if len(items) > most else "")


def rig_problems(cameras: list[CameraHealth], calibrated: list[str] | None,
                 criteria: RigCriteria = RigCriteria()) -> list[str]:
    """What is wrong with the rig now (empty: fit to record). ``calibrated``: the camera names of the
    calibration in use (None: no calibration, only the live cameras are judged)."""
    working = {c.name: c for c in cameras if c.has_signal}
    if not working:
        return [NO_CAMERA]
    problems = []
    if calibrated:
        seen = {c.name: c for c in cameras}
        down = [f"{n} ({seen[n].status})" if n in seen else f"{n} (not seen)" for n in calibrated if n not in working]
        if down:
            problems.append(f"{len(down)} of the {len(calibrated)} calibrated cameras are not working: {_names(down)}")
    slow = [f"{c.name} {c.fps:.0f} fps" for c in working.values() if c.fps < criteria.start_min_fps]
    if slow:
        problems.append(f"{len(slow)} of {len(cameras)} cameras deliver far below {criteria.min_fps:.0f} fps: "
                        f"{_names(slow)}")
    return problems


def recorder_warnings(summary: dict) -> list[str]:
    """Plain-word warnings from the recorder's summary at Stop (frames dropped on a slow disk, a write
    error)."""
    out = []
    messages = {c: int(n) for c, n in (summary.get("dropped_frames") or {}).items() if n}
    images = {c: int(n) for c, n in (summary.get("dropped_images") or {}).items() if n}
    if messages:  # dropped_frames: every message dropped (images, keypoints, status); dropped_images: the images
        others = sum(messages.values()) - sum(images.values())
        per_camera = f" ({_names([f'{c} {n}' for c, n in sorted(images.items())])})" if images else ""
        out.append(f"The recorder dropped {sum(images.values())} camera images{per_camera} and {others} "
                   "keypoint and status messages because the disk or CPU was too slow")
    if summary.get("error"):
        out.append(f"Recording error: {summary['error']}")
    return out


def calibration_problems(rig, *, metadata: dict, in_service: list[str]) -> list[str]:
    """Why a calibration cannot be used with the rig in service (empty: it can). ``rig``: the
    calibration's cameras (:class:`~gaitcap.reconstruction.camera.Rig`); ``metadata``: its TOML
    ``[metadata]``; ``in_service``: the cameras seen on the bus (empty: names not checked)."""
    problems = []
    names = list(rig.names)
    if len(names) < 2:
        problems.append(f"cameras: a calibration needs at least 2 cameras, this one has {len(names)} ({_names(names)})")
    if in_service:
        unknown = [n for n in names if n not in in_service]
        missing = [n for n in in_service if n not in names]
        if unknown:
            problems.append(f"cameras: {_names(unknown, 10)} not in the rig (cameras in service: "
                            f"{_names(sorted(in_service), 10)}); map them with camera_map")
        if missing:
            problems.append(f"cameras: {_names(missing, 10)} in service but not in the calibration")
    for cam in rig.cameras:
        w, h = cam.size_px
        fx, fy, cx, cy = cam.matrix_px[0, 0], cam.matrix_px[1, 1], cam.matrix_px[0, 2], cam.matrix_px[1, 2]
        if not (0.2 * w <= fx <= 20 * w and 0.2 * w <= fy <= 20 * w):
            problems.append(f"camera {cam.name}: focal length {fx:.0f}, {fy:.0f} px implausible for a {w}x{h} image")
        if not (0 < cx < w and 0 < cy < h):
            problems.append(f"camera {cam.name}: principal point ({cx:.0f}, {cy:.0f}) px outside the {w}x{h} image")
    error = metadata.get("error")
    if not isinstance(error, int | float) or isinstance(error, bool) or not error >= 0:
        problems.append("metadata.error: the calibration carries no reprojection error (px); "
                        "a calibration without its quality is not used")
    return problems
