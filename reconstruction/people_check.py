"""Does a reconstruction follow one person? The views' detections of "the patient" checked against it.

When the cameras' people cannot be made to agree (each camera kept its own most confident person, or the
association joined two people), the triangulated points lie between them or on one of them, and the other
views reproject far from their detections: much farther than the rig's calibration error, and farther than
a detector's keypoint noise, which grows with the person's size in the image. Each camera frame is judged
by the median over its confident joints of the reprojection error (px) against
``max(rig_factor x rig_error_px, size_fraction x the person's height in that image px)``; the
reconstruction mixes people when more than ``max_disagreeing_fraction`` of the judged camera frames are
beyond it. Pure computation: detections, rig and points in, a :class:`PersonCheck` out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.metrics import reprojection_errors_px


@dataclass(frozen=True)
class PersonCheckConfig:
    """Thresholds of :func:`check_one_person`.

    Attributes:
        rig_error_px: the rig's reprojection error (px; the calibration's RMS).
        rig_factor: a camera frame disagrees when its median error exceeds this many rig errors ...
        size_fraction: ... and this fraction of the person's height in that image (detector noise).
        min_confidence: keypoints below this confidence are not judged.
        min_joints: camera frames with fewer confident joints are not judged.
        max_disagreeing_fraction: the reconstruction mixes people when more judged camera frames than
            this fraction disagree.
    """

    rig_error_px: float = 1.0
    rig_factor: float = 20.0
    size_fraction: float = 0.1
    min_confidence: float = 0.5
    min_joints: int = 4
    max_disagreeing_fraction: float = 0.2

    def __post_init__(self) -> None:
        for name in ("rig_error_px", "rig_factor", "size_fraction", "min_confidence", "max_disagreeing_fraction"):
            if not float(getattr(self, name)) >= 0:
                raise ValueError(f"PersonCheckConfig.{name} must be >= 0, got {getattr(self, name)}")
        if self.min_joints < 1:
            raise ValueError(f"PersonCheckConfig.min_joints must be >= 1, got {self.min_joints}")


@dataclass(frozen=True)
class PersonCheck:
    """Verdict of :func:`check_one_person`.

    Attributes:
        mixed: True when the views' people do not agree (the reconstruction is not one person).
        message: one sentence saying so, with the figures and the cameras concerned.
        median_error_px: median over judged camera frames of their median reprojection error (px).
        disagreeing_fraction: fraction of judged camera frames beyond their limit.
        judged_camera_frames: how many camera frames had enough confident joints to be judged.
        per_camera_error_px: each camera's median over its judged frames (px; NaN when none).
        per_camera_disagreeing: each camera's fraction of judged frames beyond the limit.
        limit_px: median over judged camera frames of their limit (px).
    """

    mixed: bool
    message: str
    median_error_px: float
    disagreeing_fraction: float
    judged_camera_frames: int
    per_camera_error_px: dict[str, float]
    per_camera_disagreeing: dict[str, float]
    limit_px: float

    def to_dict(self) -> dict:
        nan_none = lambda v: None if not np.isfinite(v) else float(v)  # noqa: E731
        return {"mixed": self.mixed, "message": self.message, "median_error_px": nan_none(self.median_error_px),
                "disagreeing_fraction": nan_none(self.disagreeing_fraction),
                "judged_camera_frames": self.judged_camera_frames,
                "per_camera_error_px": {k: nan_none(v) for k, v in self.per_camera_error_px.items()},
                "per_camera_disagreeing": {k: nan_none(v) for k, v in self.per_camera_disagreeing.items()},
                "limit_px": nan_none(self.limit_px)}


def _frame_errors(detections: MultiViewKeypoints, rig: Rig, points_mm: np.ndarray, config: PersonCheckConfig):
    """(C, T) median reprojection error over confident joints, (C, T) limit px, (C, T) judged mask."""
    err = reprojection_errors_px(points_mm, detections, rig)  # (C, T, J)
    kp = detections.one_person
    ok = np.isfinite(kp).all(-1) & (np.nan_to_num(kp[..., 2]) >= config.min_confidence) & np.isfinite(err)
    judged = ok.sum(-1) >= config.min_joints
    err = np.where(ok, err, np.nan)
    y = np.where(ok, kp[..., 1], np.nan)
    with np.errstate(all="ignore"):
        frame_err = np.nanmedian(np.where(judged[..., None], err, 0.0), axis=-1)
        height = np.nanmax(np.where(judged[..., None], y, 0.0), -1) - np.nanmin(np.where(judged[..., None], y, 0.0), -1)
    limit = np.maximum(config.rig_factor * config.rig_error_px, config.size_fraction * height)
    return frame_err, limit, judged


def check_one_person(detections: MultiViewKeypoints, rig: Rig, points_mm: np.ndarray, *,
                     config: PersonCheckConfig = PersonCheckConfig()) -> PersonCheck:
    """Whether ``points_mm`` (T, J, 3, mm; NaN where not reconstructed) is one person seen by every view
    of ``detections`` (C, T, J; the patient's keypoints, px) through ``rig`` (see the module docstring).

    Raises ValueError naming what does not match (frames, joints, a camera missing from the rig)."""
    points = np.asarray(points_mm, dtype=np.float64)
    c, t, _, j = detections.shape
    if points.shape != (t, j, 3):
        raise ValueError(f"points_mm: expected shape ({t}, {j}, 3) for the detections' frames and joints, "
                         f"got {points.shape}")
    frame_err, limit, judged = _frame_errors(detections, rig, points, config)
    n = int(judged.sum())
    if n == 0:
        return PersonCheck(False, "no camera frame has enough confident joints to check the people", np.nan, np.nan,
                           0, {}, {}, np.nan)
    beyond = judged & (frame_err > limit)
    per_err, per_bad = {}, {}
    for k, name in enumerate(detections.camera_names):
        m = judged[k]
        per_err[name] = float(np.median(frame_err[k][m])) if m.any() else float("nan")
        per_bad[name] = float(beyond[k].sum() / m.sum()) if m.any() else float("nan")
    fraction = float(beyond.sum() / n)
    median, lim = float(np.median(frame_err[judged])), float(np.median(limit[judged]))
    mixed = fraction > config.max_disagreeing_fraction
    worst = [name for name, f in sorted(per_bad.items(), key=lambda kv: -np.nan_to_num(kv[1]))
             if np.isfinite(f) and f > config.max_disagreeing_fraction]
    if mixed:
        named = ", ".join(f"{name} {per_err[name]:.0f} px in {per_bad[name]:.0%} of its frames" for name in worst)
        message = (f"the views do not agree on one person: {fraction:.0%} of {n} camera frames reproject beyond "
                   f"their limit (median {lim:.0f} px; rig {config.rig_error_px:g} px)"
                   + (f": {named}" if named else "")
                   + "; the reconstruction likely mixes people (check who each camera sees)")
    else:
        message = (f"one person: median reprojection {median:.1f} px, {fraction:.0%} of {n} camera frames beyond "
                   f"their limit (median {lim:.0f} px)")
    return PersonCheck(mixed, message, median, fraction, n, per_err, per_bad, lim)
