"""Person boxes per camera reprojected from a 3D reconstruction (the input of top-down detectors)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.camera import Rig


@dataclass(frozen=True)
class BoxConfig:
    """How boxes are grown around the reprojected joints.

    Attributes:
        padding_fraction: each side moves out by this fraction of the box's width (x) or height (y).
        min_padding_px: ... but by at least this many px.
        min_joints: fewer joints in front of the camera (and finite) gives no box (NaN).
        min_size_px: boxes narrower or lower than this after clipping are dropped (NaN).
    """

    padding_fraction: float = 0.15
    min_padding_px: float = 10.0
    min_joints: int = 2
    min_size_px: float = 4.0

    def __post_init__(self) -> None:
        if self.padding_fraction < 0 or self.min_padding_px < 0 or self.min_size_px < 0:
            raise ValueError("BoxConfig: paddings and min_size_px must be >= 0")
        if self.min_joints < 1:
            raise ValueError("BoxConfig.min_joints must be >= 1")


def person_boxes(rig: Rig, points_mm: np.ndarray, config: BoxConfig = BoxConfig()) -> np.ndarray:
    """Boxes around one person in every camera.

    Args:
        rig: C cameras.
        points_mm: (T, J, 3) the person's 3D joints (NaN allowed).
        config: padding and validity rules.
    Returns:
        (C, T, 4) boxes x0, y0, x1, y1 in px, padded and clipped to each image; NaN rows where the
        person is not in front of the camera, has too few joints or falls outside the image.
    """
    points_mm = np.asarray(points_mm, dtype=np.float64)
    if points_mm.ndim != 3 or points_mm.shape[-1] != 3:
        raise ValueError(f"points_mm: expected shape (T, J, 3), got {points_mm.shape}")
    boxes = []
    for cam in rig.cameras:
        front = cam.depth_mm(points_mm) > 1.0  # NaN compares False
        px = np.where(front[..., None], cam.project(np.nan_to_num(points_mm)), np.nan)
        boxes.append(_box(px, np.array(cam.size_px, float), config))
    return np.stack(boxes)


def _box(px: np.ndarray, size: np.ndarray, config: BoxConfig) -> np.ndarray:
    """(T, J, 2) px -> (T, 4) padded, clipped boxes (NaN where invalid)."""
    n = np.isfinite(px).all(-1).sum(-1)
    enough = n >= config.min_joints
    safe = np.where(enough[:, None, None], px, 0.0)
    lo, hi = np.nanmin(safe, axis=1), np.nanmax(safe, axis=1)  # (T, 2)
    pad = np.maximum(config.padding_fraction * (hi - lo), config.min_padding_px)
    lo, hi = np.clip(lo - pad, 0, size), np.clip(hi + pad, 0, size)
    ok = enough & ((hi - lo) >= config.min_size_px).all(-1)
    out = np.concatenate([lo, hi], -1)
    out[~ok] = np.nan
    return out


def track_boxes(rig: Rig, points_mm: np.ndarray, camera_names, config: BoxConfig = BoxConfig()) -> np.ndarray:
    """Boxes from a track's own association joints (``Tracks.points_mm[track_id]``, (T, Ja, 3)), in the
    order of ``camera_names`` (e.g. ``Tracks.camera_names``): boxes before any full reconstruction.
    Association joints stop at the ankles, so give a larger ``padding_fraction`` to include the feet."""
    return person_boxes(rig.subset(camera_names), points_mm, config)
