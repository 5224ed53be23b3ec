"""The calibration's quality report: per camera reprojection error, detections, image coverage, and the
board's square size measured back by triangulation (the scale check)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import cv2
import numpy as np


@dataclass(frozen=True)
class QualityThresholds:
    """A camera is named as failed when it misses one of these.

    Attributes:
        max_p95_px: 95th percentile of its reprojection error, px.
        min_coverage: fraction of image cells (``grid`` columns x rows) with at least one corner.
        grid: (columns, rows) of the coverage grid.
        max_rms_ratio / rms_floor_px: a camera whose reprojection RMS is more than ``max_rms_ratio`` times
            the other cameras' median RMS (and above ``rms_floor_px``) fails: one bad camera spoils every
            triangulation it takes part in.
        min_views_kept_fraction: a camera judged on fewer than this share of its views as found (the rest
            moving, smeared during the readout or left out as disagreeing) fails: too little to judge it on.
    """

    max_p95_px: float = 3.0
    min_coverage: float = 0.3
    grid: tuple[int, int] = (8, 5)
    max_rms_ratio: float = 2.5
    rms_floor_px: float = 0.5
    min_views_kept_fraction: float = 0.5


@dataclass(frozen=True)
class CameraQuality:
    """One camera: board views used, corners (inliers / outliers), reprojection error (px: mean, p95, RMS,
    median) and coverage; views_found: views the detector gave; views_kept_fraction: used / found;
    views_left_out: views left out as disagreeing with the other cameras as a whole (not used, not
    judged); views_undecidable: views disagreeing as a whole in frame sets that could not tell which camera
    was wrong (kept and judged); notes: what was left out or kept and why, plain words; held: which
    intrinsics were held because its views could not determine them, and why (also in notes);
    focal_rel_std: its focal length's relative standard deviation from its own views (NaN: intrinsics
    given, not estimated)."""

    name: str
    n_detections: int
    n_corners: int
    n_outliers: int
    reprojection_mean_px: float
    reprojection_p95_px: float
    reprojection_rms_px: float
    coverage: float
    ok: bool
    problems: tuple[str, ...]
    median_px: float = float("nan")
    views_found: int = 0
    views_kept_fraction: float = float("nan")
    views_left_out: int = 0
    notes: tuple[str, ...] = ()
    views_undecidable: int = 0
    held: tuple[str, ...] = ()
    focal_rel_std: float = float("nan")


@dataclass(frozen=True)
class QualityReport:
    """The whole calibration. Reprojection RMS is sqrt(mean |e|^2) over inlier corners (|e| is the 2D
    error), i.e. sqrt(2) x the per-axis pixel noise for a perfect fit.

    board_check: the board triangulated from the inlier corners and measured in 3D after the fit
    (:class:`~gaitcap.reconstruction.calibration.board_check.BoardCheck` as a dict: square size overall,
    along columns and rows, square error, flatness, shape, mm); board_problems: what that check found
    wrong (plain words). outlier_threshold_px: the bundle adjustment's last outlier threshold (px);
    outlier_corners: {camera: [{"frame": given frame index, "corners": [corner ids], "max_px": largest
    error}]}: every corner dropped as an outlier, named per camera and frame. motion: what the board's
    motion did (:class:`~gaitcap.reconstruction.calibration.motion.MotionReport` as a dict: each camera's
    time offset, the views' weights by speed; empty: not modelled)."""

    board: str
    distortion: str
    cameras: tuple[CameraQuality, ...]
    failed_cameras: tuple[str, ...]
    n_frames: int
    n_corners: int
    n_outliers: int
    reprojection_mean_px: float
    reprojection_p95_px: float
    reprojection_rms_px: float
    square_mm: float
    square_measured_mm: float
    square_residual_pct: float
    floor_frames: int
    world_flipped: bool
    bundle_rounds: int
    solve_time_s: float
    board_check: dict | None = None
    board_problems: tuple[str, ...] = ()
    outlier_threshold_px: float = float("nan")
    outlier_corners: dict = field(default_factory=dict)
    motion: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return asdict(self)


def error_stats(err_px: np.ndarray) -> tuple[float, float, float]:
    """(mean, p95, rms) of 2D error norms (P,) px; NaN when empty."""
    if err_px.size == 0:
        return float("nan"), float("nan"), float("nan")
    return float(err_px.mean()), float(np.percentile(err_px, 95)), float(np.sqrt(np.mean(err_px**2)))


def coverage(uv_px: np.ndarray, size_px: tuple[int, int], grid: tuple[int, int]) -> float:
    """Fraction of the image's grid cells that hold at least one corner (uv_px: (P, 2))."""
    w, h = size_px
    gx = np.clip((uv_px[:, 0] / w * grid[0]).astype(int), 0, grid[0] - 1)
    gy = np.clip((uv_px[:, 1] / h * grid[1]).astype(int), 0, grid[1] - 1)
    return len(set(zip(gx.tolist(), gy.tolist(), strict=True))) / (grid[0] * grid[1])


def triangulate_normalized(xy: np.ndarray, extrinsics: np.ndarray) -> np.ndarray:
    """DLT: undistorted normalised points (C, P, 2) (NaN = unseen) and [R|t] (C, 3, 4) -> (P, 3) mm.
    Points seen by fewer than two cameras come back NaN."""
    seen = np.all(np.isfinite(xy), -1)
    x = np.where(seen[..., None], xy, 0.0)
    rows_x = x[..., 0:1] * extrinsics[:, None, 2] - extrinsics[:, None, 0]  # (C, P, 4)
    rows_y = x[..., 1:2] * extrinsics[:, None, 2] - extrinsics[:, None, 1]
    a = np.concatenate([rows_x, rows_y], 0) * np.concatenate([seen, seen], 0)[..., None]
    _, _, vt = np.linalg.svd(np.transpose(a, (1, 0, 2)))
    hom = vt[:, -1]
    with np.errstate(divide="ignore", invalid="ignore"):
        pts = hom[:, :3] / hom[:, 3:4]
    pts[seen.sum(0) < 2] = np.nan
    return pts


def triangulate_board(corners_px: np.ndarray, matrix_px: np.ndarray, dist: np.ndarray,
                      extrinsics: np.ndarray) -> np.ndarray:
    """(F, N, 3) mm: corners (C, F, N, 2) px in the board's true order (NaN: unseen) triangulated with
    K (C, 3, 3), dist (C, 5) and [R|t] (C, 3, 4); NaN where fewer than 2 cameras saw the corner."""
    c_count, f_count, n, _ = corners_px.shape
    xy = np.full((c_count, f_count * n, 2), np.nan)
    for c in range(c_count):
        flat = corners_px[c].reshape(-1, 2)
        ok = np.all(np.isfinite(flat), -1)
        if ok.any():
            xy[c, ok] = cv2.undistortPoints(flat[ok].reshape(-1, 1, 2), matrix_px[c], dist[c]).reshape(-1, 2)
    return triangulate_normalized(xy, extrinsics).reshape(f_count, n, 3)


def measured_square_mm(
    corners_px: np.ndarray, matrix_px: np.ndarray, dist: np.ndarray, extrinsics: np.ndarray, neighbours: np.ndarray
) -> float:
    """Median distance (mm) between triangulated neighbouring corners.

    corners_px: (C, F, N, 2) in the board's true corner order, NaN where unseen or rejected.
    """
    pts = triangulate_board(corners_px, matrix_px, dist, extrinsics)
    d = np.linalg.norm(pts[:, neighbours[:, 0]] - pts[:, neighbours[:, 1]], axis=-1)
    d = d[np.isfinite(d)]
    return float(np.median(d)) if d.size else float("nan")
