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


class PrincipalPoint(enum.Enum):
    """Where a camera's principal point comes from: held at the image centre when the board covered too
    little of the image (``BY_COVERAGE``, the rule below), always held there, or always free (a focal
    length the views leave uncertain still holds it: ``IntrinsicsConfig.hold_undetermined``)."""

    BY_COVERAGE = "by coverage"
    HELD = "held"
    FREE = "free"


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
            the image); the distortion terms beyond k1 are then held at 0 too (such views do not determine
            them: k1k2 and all five terms put that session's rig further from caliscope's, not nearer).
        hold_undetermined: a camera whose focal length is uncertain by more than ``max_focal_rel_std``
            with its principal point free is calibrated again with the principal point held at the image
            centre and only k1 (fewer unknowns for the same views); only when it is still uncertain beyond
            ``max_focal_rel_std`` is it refused, with both figures. False: refused at once.
    """

    distortion: DistortionModel = DistortionModel.K1
    max_views: int = 40
    min_views: int = 6
    max_focal_rel_std: float = 0.15
    min_tilt: float = 0.03
    min_tilted_views: int = 3
    principal_point_min_coverage: float = 0.3
    coverage_grid: tuple[int, int] = (8, 5)
    hold_undetermined: bool = True
    principal_point: PrincipalPoint = PrincipalPoint.BY_COVERAGE
    chosen_because: str = ""


@dataclass(frozen=True, eq=False)
class Intrinsics:
    """K (3, 3) px and dist (5,) of one camera, with calibrateCamera's RMS (px); principal_point_held: the
    principal point was held at the image centre; distortion_held: indices into (k1, k2, p1, p2, k3) held
    at 0 although the model frees them; held: why, plain words (one line per decision);
    focal_rel_std: the focal length's relative standard deviation from the camera's own views as finally
    fitted (NaN: not estimated here)."""

    matrix_px: np.ndarray
    dist: np.ndarray
    rms_px: float
    principal_point_held: bool = False
    distortion_held: tuple[int, ...] = ()
    held: tuple[str, ...] = ()
    focal_rel_std: float = float("nan")


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


def _focal_rel_std(k: np.ndarray, std_intr: np.ndarray) -> float:
    """The focal length's relative standard deviation from calibrateCameraExtended's stds (inf when NaN)."""
    rel = float(np.max(std_intr.ravel()[:2]) / max(k[0, 0], 1e-9))
    return rel if np.isfinite(rel) else float("inf")


_TERMS = ("k1", "k2", "p1", "p2", "k3")


def _held_fit(name, obj, img, size_px, k0, config: IntrinsicsConfig, why: str):
    """Calibrate again with the principal point at the image centre and only k1 (what bunched views
    cannot determine held): (rms, K, dist, focal rel std, distortion held, reasons)."""
    dropped = tuple(i for i in config.distortion.free if i != 0)
    flags = DistortionModel.K1.cv2_flags | cv2.CALIB_USE_INTRINSIC_GUESS | cv2.CALIB_FIX_PRINCIPAL_POINT
    rms, k, dist, std_intr = _calibrate(name, obj, img, size_px, k0, flags)
    reasons = [f"principal point held at the image centre: {why}"]
    if dropped:
        reasons.append(f"distortion {', '.join(_TERMS[i] for i in dropped)} held at 0 (only k1 fitted): {why}")
    return rms, k, dist, _focal_rel_std(k, std_intr), dropped, tuple(reasons)


def _why_hold(focal_std: float, covered: float, config: IntrinsicsConfig) -> str | None:
    """Why the camera's views cannot determine every intrinsic (None: they can)."""
    if focal_std > config.max_focal_rel_std:
        return (f"with it free the focal length was uncertain by {100 * focal_std:.1f} % "
                f"(> {100 * config.max_focal_rel_std:.0f} %)")
    if config.principal_point is PrincipalPoint.BY_COVERAGE and covered < config.principal_point_min_coverage:
        return (f"the board covered {100 * covered:.0f} % of the image "
                f"(< {100 * config.principal_point_min_coverage:.0f} %)")
    return None


def _views(obs: BoardObservations, cam: int, config: IntrinsicsConfig):
    """The camera's chosen views as calibrateCamera takes them (object mm, image px); ValueError naming
    the camera when too few or too flat."""
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
    return obj, img


def _asked_held(name, obj, img, size_px, k0, flags: int, config: IntrinsicsConfig) -> Intrinsics:
    """The principal point held at the image centre because the config asks it, the distortion model
    as given; refused (ValueError naming the camera) when the focal length stays uncertain."""
    rms, k, dist, std_intr = _calibrate(name, obj, img, size_px, k0, flags | cv2.CALIB_FIX_PRINCIPAL_POINT)
    focal_std = _focal_rel_std(k, std_intr)
    if focal_std > config.max_focal_rel_std:
        raise _degenerate(name, f"focal length uncertain by {100 * focal_std:.1f} % with the principal point held")
    dist = np.asarray(dist, dtype=np.float64).ravel()[:5]
    why = (config.chosen_because,) if config.chosen_because else ()
    return Intrinsics(k, np.pad(dist, (0, 5 - dist.size)), float(rms), True, (), why, focal_std)


def estimate_intrinsics(obs: BoardObservations, cam: int, config: IntrinsicsConfig) -> Intrinsics:
    """Calibrate camera ``cam``'s intrinsics from its own board views (each view on its own); what the
    views cannot determine is held (``IntrinsicsConfig``), and the result says what and why."""
    name = obs.camera_names[cam]
    obj, img = _views(obs, cam, config)
    w, h = obs.image_sizes_px[cam]
    k0 = np.array([[max(w, h), 0, w / 2], [0, max(w, h), h / 2], [0, 0, 1]], dtype=np.float64)
    flags = config.distortion.cv2_flags | cv2.CALIB_USE_INTRINSIC_GUESS
    if config.principal_point is PrincipalPoint.HELD:
        return _asked_held(name, obj, img, (w, h), k0, flags, config)
    rms, k, dist, std_intr = _calibrate(name, obj, img, (w, h), k0, flags)
    free_std = focal_std = _focal_rel_std(k, std_intr)
    why = _why_hold(focal_std, coverage(obs.corners_px[cam][obs.seen()[cam]], (w, h), config.coverage_grid), config)
    held_dist, held = (), ()
    if why is not None and config.hold_undetermined:
        rms, k, dist, focal_std, held_dist, held = _held_fit(name, obj, img, (w, h), k0, config, why)
        log.info("camera %s: %s", name, "; ".join(held))
    elif why is not None:  # strict: refused when uncertain; bunched views: the principal point alone held
        if focal_std > config.max_focal_rel_std:
            raise _degenerate(name, f"focal length uncertain by {100 * focal_std:.1f} %")
        rms, k, dist, _ = _calibrate(name, obj, img, (w, h), k0, flags | cv2.CALIB_FIX_PRINCIPAL_POINT)
    if focal_std > config.max_focal_rel_std:
        raise _degenerate(name, f"focal length uncertain by {100 * free_std:.1f} % with the principal point free, "
                                f"{100 * focal_std:.1f} % with it held at the image centre and only k1")
    if not 0.1 * w < k[0, 0] < 20 * w:
        raise _degenerate(name, f"implausible focal length {k[0, 0]:.0f} px for a {w} px wide image")
    dist = np.asarray(dist, dtype=np.float64).ravel()[:5]
    log.debug("camera %s: intrinsics rms %.3f px from %d views", name, rms, len(obj))
    held += (config.chosen_because,) if config.chosen_because else ()
    return Intrinsics(k, np.pad(dist, (0, 5 - dist.size)), float(rms), why is not None, held_dist, held, focal_std)
