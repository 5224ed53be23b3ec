"""Per-camera intrinsics (K and distortion) from planar board views, with OpenCV's calibrateCamera."""

from __future__ import annotations

import enum
import logging
from dataclasses import dataclass

import cv2
import numpy as np
from gaitcap.reconstruction.calibration.geometry import BoardObservations
from gaitcap.reconstruction.calibration.report import coverage

log = logging.getLogger(__name__)


class DistortionModel(enum.Enum):
    """Which OpenCV distortion coefficients are estimated (the rest stay 0)."""

    K1 = "k1"  # the paper's single radial term
    K1K2 = "k1k2"  # two radial terms (wide-angle webcams)
    FULL = "k1k2p1p2k3"

    @property
    def free(self) -> tuple[int, ...]:
        """Indices into (k1, k2, p1, p2, k3) that are estimated."""
        return _FREE[self]

    @property
    def cv2_flags(self) -> int:
        return _CV2_FLAGS[self]


_FREE = {DistortionModel.K1: (0,), DistortionModel.K1K2: (0, 1), DistortionModel.FULL: (0, 1, 2, 3, 4)}
_CV2_FLAGS = {
    DistortionModel.K1: cv2.CALIB_FIX_K2 | cv2.CALIB_FIX_K3 | cv2.CALIB_ZERO_TANGENT_DIST,
    DistortionModel.K1K2: cv2.CALIB_FIX_K3 | cv2.CALIB_ZERO_TANGENT_DIST,
    DistortionModel.FULL: 0,
}


@dataclass(frozen=True)
class IntrinsicsConfig:
    """How intrinsics are initialised.

    Attributes:
        distortion: which coefficients to estimate.
        max_views: at most this many views per camera go into calibrateCamera (spread over the clip).
        min_views: fewer usable views than this is an error naming the camera.
        max_focal_rel_std: relative standard deviation of the focal length above which the views are
            called degenerate.
        min_tilt / min_tilted_views: a view counts as tilted when the board's depth changes by at least
            ``min_tilt`` (relative) across it; fewer tilted views than this is degenerate (a planar board
            held parallel to the image says nothing about the focal length).
        principal_point_min_coverage / coverage_grid: when the camera's board corners fill less than this
            fraction of the image's cells (``coverage_grid`` columns x rows), its principal point is held at
            the image centre, here and in the bundle adjustment: views bunched in part of the image cannot
            tell a shifted principal point from a turned camera (on caliscope's real webcam session the
            free principal point wandered 64 px, a 4 deg turn of the camera, with the board in 10-20 % of
            the image).
    """

    distortion: DistortionModel = DistortionModel.K1
    max_views: int = 40
    min_views: int = 6
    max_focal_rel_std: float = 0.15
    min_tilt: float = 0.03
    min_tilted_views: int = 3
    principal_point_min_coverage: float = 0.3
    coverage_grid: tuple[int, int] = (8, 5)


@dataclass(frozen=True, eq=False)
class Intrinsics:
    """K (3, 3) px and dist (5,) of one camera, with calibrateCamera's RMS (px); principal_point_held: the
    principal point was held at the image centre (too little of the image covered to estimate it)."""

    matrix_px: np.ndarray
    dist: np.ndarray
    rms_px: float
    principal_point_held: bool = False


def _pick_views(frames: np.ndarray, counts: np.ndarray, max_views: int) -> np.ndarray:
    """Up to ``max_views`` frames spread evenly over the clip, preferring views with many corners."""
    if len(frames) <= max_views:
        return frames
    chunks = np.array_split(np.arange(len(frames)), max_views)
    return np.array([frames[ch[np.argmax(counts[ch])]] for ch in chunks])


def view_tilt(object_points_mm: np.ndarray, image_px: np.ndarray) -> float:
    """Relative depth change across a planar view, from the homography's projective row (0 = parallel)."""
    hom, _ = cv2.findHomography(object_points_mm[:, :2], image_px, 0)
    if hom is None or abs(hom[2, 2]) < 1e-12:
        return 0.0
    extent = float(np.ptp(object_points_mm[:, :2], axis=0).max())
    return float(np.linalg.norm(hom[2, :2] / hom[2, 2]) * extent)


def _degenerate(name: str, why: str) -> ValueError:
    return ValueError(
        f"camera {name!r}: board views are degenerate for intrinsics ({why}); tilt the board (about "
        "+-30 deg) and move it across the whole image"
    )


def _calibrate(name: str, obj: list, img: list, size_px: tuple[int, int], k0: np.ndarray, flags: int):
    """calibrateCameraExtended: (rms px, K, dist, std of the intrinsics); ValueError naming the camera."""
    try:
        rms, k, dist, _, _, std_intr, _, _ = cv2.calibrateCameraExtended(obj, img, size_px, k0.copy(), np.zeros(5),
                                                                         flags=flags)
    except cv2.error as exc:
        raise ValueError(f"camera {name!r}: intrinsic calibration failed ({exc.msg.strip()})") from None
    return float(rms), np.asarray(k, dtype=np.float64), dist, std_intr


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
    tilted = sum(view_tilt(o, i) > config.min_tilt for o, i in zip(obj, img, strict=True))
    if tilted < config.min_tilted_views:
        raise _degenerate(name, f"only {tilted} of {len(chosen)} views are tilted against the image plane")
    w, h = obs.image_sizes_px[cam]
    k0 = np.array([[max(w, h), 0, w / 2], [0, max(w, h), h / 2], [0, 0, 1]], dtype=np.float64)
    flags = config.distortion.cv2_flags | cv2.CALIB_USE_INTRINSIC_GUESS
    rms, k, dist, std_intr = _calibrate(name, obj, img, (w, h), k0, flags)
    focal_rel_std = float(np.max(std_intr.ravel()[:2]) / max(k[0, 0], 1e-9))
    if not np.isfinite(focal_rel_std) or focal_rel_std > config.max_focal_rel_std:
        raise _degenerate(name, f"focal length uncertain by {100 * focal_rel_std:.1f} %")
    covered = coverage(obs.corners_px[cam][seen], (w, h), config.coverage_grid)
    hold_pp = covered < config.principal_point_min_coverage
    if hold_pp:  # the focal length was judged with the principal point free: holding it hides no degeneracy
        log.info("camera %s: board covers %.0f %% of the image: principal point held at the image centre",
                 name, 100 * covered)
        rms, k, dist, _ = _calibrate(name, obj, img, (w, h), k0, flags | cv2.CALIB_FIX_PRINCIPAL_POINT)
    if not 0.1 * w < k[0, 0] < 20 * w:
        raise _degenerate(name, f"implausible focal length {k[0, 0]:.0f} px for a {w} px wide image")
    dist = np.asarray(dist, dtype=np.float64).ravel()[:5]
    log.debug("camera %s: intrinsics rms %.3f px from %d views", name, rms, len(chosen))
    return Intrinsics(k, np.pad(dist, (0, 5 - dist.size)), float(rms), hold_pp)
