"""Per-camera intrinsics (K and distortion) from planar board views, with OpenCV's calibrateCamera."""

from __future__ import annotations

import enum
import logging
from dataclasses import dataclass

import cv2
import numpy as np

from reconstruction.calibration.geometry import BoardObservations

log = logging.getLogger(__name__)


class DistortionModel(enum.Enum):
    """Which OpenCV distortion coefficients are estimated (the rest stay 0)."""

    K1 = "k1"  # the paper's single radial term
    FULL = "k1k2p1p2k3"

    @property
    def free(self) -> tuple[int, ...]:
        """Indices into (k1, k2, p1, p2, k3) that are estimated."""
        return (0,) if self is DistortionModel.K1 else (0, 1, 2, 3, 4)

    @property
    def cv2_flags(self) -> int:
        if self is DistortionModel.K1:
            return cv2.CALIB_FIX_K2 | cv2.CALIB_FIX_K3 | cv2.CALIB_ZERO_TANGENT_DIST
        return 0


@dataclass(frozen=True)
class IntrinsicsConfig:
    """How intrinsics are initialised.

    Attributes:
        distortion: which coefficients to estimate.
        max_views: at most this many views per camera go into calibrateCamera (spread over the clip).
        min_views: fewer usable views than this is an error naming the camera.
        max_focal_rel_std: relative standard deviation of the focal length above which the views are
            called degenerate (e.g. all fronto-parallel).
    """

    distortion: DistortionModel = DistortionModel.K1
    max_views: int = 40
    min_views: int = 6
    max_focal_rel_std: float = 0.15


@dataclass(frozen=True, eq=False)
class Intrinsics:
    """K (3, 3) px and dist (5,) of one camera, with calibrateCamera's RMS (px)."""

    matrix_px: np.ndarray
    dist: np.ndarray
    rms_px: float


def _pick_views(frames: np.ndarray, counts: np.ndarray, max_views: int) -> np.ndarray:
    """Up to ``max_views`` frames spread evenly over the clip, preferring views with many corners."""
    if len(frames) <= max_views:
        return frames
    chunks = np.array_split(np.arange(len(frames)), max_views)
    return np.array([frames[ch[np.argmax(counts[ch])]] for ch in chunks])


def estimate_intrinsics(obs: BoardObservations, cam: int, config: IntrinsicsConfig) -> Intrinsics:
    """Calibrate camera ``cam``'s intrinsics from its own board views (each view on its own)."""
    name = obs.camera_names[cam]
    views = np.flatnonzero(obs.views()[cam])
    if len(views) < config.min_views:
        raise ValueError(
            f"camera {name!r}: only {len(views)} usable board views (need at least {config.min_views}); "
            "record longer and move the board through this camera's whole image"
        )
    seen = obs.seen()[cam]
    chosen = _pick_views(views, seen[views].sum(-1), config.max_views)
    obj = [obs.board.object_points_mm[seen[f]].astype(np.float32) for f in chosen]
    img = [obs.corners_px[cam, f][seen[f]].astype(np.float32) for f in chosen]
    w, h = obs.image_sizes_px[cam]
    k0 = np.array([[max(w, h), 0, w / 2], [0, max(w, h), h / 2], [0, 0, 1]], dtype=np.float64)
    flags = config.distortion.cv2_flags | cv2.CALIB_USE_INTRINSIC_GUESS
    try:
        rms, k, dist, _, _, std_intr, _, _ = cv2.calibrateCameraExtended(
            obj, img, (w, h), k0, np.zeros(5), flags=flags
        )
    except cv2.error as exc:
        raise ValueError(f"camera {name!r}: intrinsic calibration failed ({exc.msg.strip()})") from None
    k = np.asarray(k, dtype=np.float64)
    focal_rel_std = float(np.max(std_intr.ravel()[:2]) / max(k[0, 0], 1e-9))
    if not np.isfinite(focal_rel_std) or focal_rel_std > config.max_focal_rel_std or k[0, 0] <= 0:
        raise ValueError(
            f"camera {name!r}: board views are degenerate for intrinsics (focal length uncertain by "
            f"{100 * focal_rel_std:.1f} %); tilt the board (about +-30 deg) and move it across the image"
        )
    dist = np.asarray(dist, dtype=np.float64).ravel()[:5]
    log.debug("camera %s: intrinsics rms %.3f px from %d views", name, rms, len(chosen))
    return Intrinsics(k, np.pad(dist, (0, 5 - dist.size)), float(rms))
