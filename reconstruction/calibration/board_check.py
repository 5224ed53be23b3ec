"""The board's own geometry measured in 3D with a calibration: its corners triangulated from every camera
that saw them (each frame set on its own), then the square size along the board's columns and rows, the
flatness, and the board's shape after the best rigid fit, against the board as described.

A calibration fitted to these corners takes its scale from the described square, so a board described
with a uniformly wrong square size cannot show here (the images alone do not tell the scale); it shows
when another calibration, made with the true size, is measured on the same corners (its squares come back
at the true size), and that is what :func:`size_problem` names. A printer that scaled the columns and
rows differently, or a bent board, show in any calibration.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.calibration.geometry import BoardGeometry
from gaitcap.reconstruction.calibration.report import triangulate_board


@dataclass(frozen=True)
class BoardCheck:
    """The board measured in 3D (mm).

    Attributes:
        frames: frame sets with at least 4 corners triangulated; points: corners triangulated.
        square_mm: median distance between neighbouring corners; square_cols_mm / square_rows_mm: the
            same along the board's columns (x) and rows (y).
        square_error_rms_mm: RMS of (neighbour distance - described square).
        flatness_rms_mm: RMS distance of the corners from each frame's best plane.
        shape_rms_mm: RMS distance of the corners from the described board after each frame's best rigid
            fit (square size, flatness and everything else together).
        described_square_mm: the square as described.
        per_camera_square_error_rms_mm: {camera: square_error_rms_mm over the neighbour pairs it saw}.
    """

    frames: int
    points: int
    square_mm: float
    square_cols_mm: float
    square_rows_mm: float
    square_error_rms_mm: float
    flatness_rms_mm: float
    shape_rms_mm: float
    described_square_mm: float
    per_camera_square_error_rms_mm: dict[str, float]

    @property
    def square_residual_pct(self) -> float:
        return 100 * (self.square_mm / self.described_square_mm - 1)


def _rms(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x**2))) if x.size else float("nan")


def _median(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return float(np.median(x)) if x.size else float("nan")


def _plane_distances(pts: np.ndarray) -> np.ndarray:
    """(N,) signed distances of one frame's points (N, 3) (NaN rows ignored) from their best plane."""
    ok = np.all(np.isfinite(pts), -1)
    out = np.full(len(pts), np.nan)
    if ok.sum() < 4:
        return out
    centred = pts[ok] - pts[ok].mean(0)
    normal = np.linalg.svd(centred, full_matrices=False)[2][-1]
    out[ok] = centred @ normal
    return out


def _rigid_residuals(obj: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """(N,) distances (mm) of the points (N, 3) from the board's corners ``obj`` (N, 3) after the best
    rigid fit (Kabsch); NaN where a point is missing or fewer than 4 are there."""
    ok = np.all(np.isfinite(pts), -1)
    out = np.full(len(pts), np.nan)
    if ok.sum() < 4:
        return out
    a, b = obj[ok] - obj[ok].mean(0), pts[ok] - pts[ok].mean(0)
    u, _, vt = np.linalg.svd(a.T @ b)
    d = np.sign(np.linalg.det(u @ vt))
    rot = (u @ np.diag([1.0, 1.0, d]) @ vt).T
    out[ok] = np.linalg.norm(b - a @ rot.T, axis=-1)
    return out


@dataclass(frozen=True, eq=False)
class BoardMeasures:
    """Raw 3D measures of one calibration's triangulated board: neighbour distances (F, E) mm, each
    corner's distance from its frame's plane and from the rigidly fitted board (F, N) mm, and which
    neighbour pairs each camera saw (C, F, E)."""

    length_mm: np.ndarray
    plane_mm: np.ndarray
    shape_mm: np.ndarray
    cam_pairs: np.ndarray
    points: int


def measure_board(corners_px: np.ndarray, matrix_px: np.ndarray, dist: np.ndarray, extrinsics: np.ndarray,
                  board: BoardGeometry) -> BoardMeasures:
    """Triangulate and measure the board: corners (C, F, N, 2) px in its true order, NaN where unseen (or
    left out as outliers); K (C, 3, 3), dist (C, 5), [R|t] (C, 3, 4) mm. Frames with fewer than 4 corners
    triangulated are not measured."""
    pts = triangulate_board(corners_px, matrix_px, dist, extrinsics)
    counted = np.all(np.isfinite(pts), -1).sum(1) >= 4
    pts = np.where(counted[:, None, None], pts, np.nan)
    nb = board.neighbours
    length = np.linalg.norm(pts[:, nb[:, 0]] - pts[:, nb[:, 1]], axis=-1)
    seen = np.all(np.isfinite(corners_px), -1)
    empty = np.zeros((0, board.num_corners))
    plane = np.stack([_plane_distances(p) for p in pts]) if len(pts) else empty
    shape = np.stack([_rigid_residuals(board.object_points_mm, p) for p in pts]) if len(pts) else empty
    return BoardMeasures(length, plane, shape, seen[:, :, nb[:, 0]] & seen[:, :, nb[:, 1]],
                         int(np.all(np.isfinite(pts), -1).sum()))


def summarize_board(parts: list[BoardMeasures], board: BoardGeometry, camera_names: tuple[str, ...]) -> BoardCheck:
    """One :class:`BoardCheck` over the measures of one or more calibrations (e.g. one per fold)."""
    n_e = len(board.neighbours)
    length = np.concatenate([p.length_mm for p in parts]) if parts else np.zeros((0, n_e))
    pairs = np.concatenate([p.cam_pairs for p in parts], 1) if parts else np.zeros((len(camera_names), 0, n_e), bool)
    plane = np.concatenate([p.plane_mm.ravel() for p in parts]) if parts else np.zeros(0)
    shape = np.concatenate([p.shape_mm.ravel() for p in parts]) if parts else np.zeros(0)
    nb = board.neighbours
    along_cols = np.abs(board.object_points_mm[nb[:, 0], 0] - board.object_points_mm[nb[:, 1], 0]) > 0
    err = length - board.square_mm
    per_cam = {name: _rms(np.where(pairs[c], err, np.nan)) for c, name in enumerate(camera_names)}
    return BoardCheck(
        frames=int(np.isfinite(length).any(1).sum()), points=sum(p.points for p in parts), square_mm=_median(length),
        square_cols_mm=_median(length[:, along_cols]), square_rows_mm=_median(length[:, ~along_cols]),
        square_error_rms_mm=_rms(err), flatness_rms_mm=_rms(plane), shape_rms_mm=_rms(shape),
        described_square_mm=board.square_mm, per_camera_square_error_rms_mm=per_cam,
    )


def check_board(corners_px: np.ndarray, matrix_px: np.ndarray, dist: np.ndarray, extrinsics: np.ndarray,
                board: BoardGeometry, camera_names: tuple[str, ...]) -> BoardCheck:
    """Measure the board in 3D with one calibration (arguments as :func:`measure_board`)."""
    return summarize_board([measure_board(corners_px, matrix_px, dist, extrinsics, board)], board, camera_names)


def size_problem(check: BoardCheck, *, max_pct: float = 1.0, who: str = "this calibration") -> str | None:
    """A plain-words problem when the board measured in 3D differs from the board as described by more
    than ``max_pct`` % in its square size or between its columns and rows (None: it agrees)."""
    if not np.isfinite(check.square_mm):
        return None
    cols, rows = check.square_cols_mm, check.square_rows_mm
    if np.isfinite(cols) and np.isfinite(rows) and abs(cols / rows - 1) * 100 > max_pct:
        return (f"board shape mismatch: triangulated with {who} its squares measure {cols:.2f} mm along the "
                f"columns and {rows:.2f} mm along the rows ({100 * (cols / rows - 1):+.1f} %): a print not at "
                "100 % in both directions?")
    if abs(check.square_residual_pct) > max_pct:
        return (f"board size mismatch: triangulated with {who} its squares measure {check.square_mm:.2f} mm, "
                f"described as {check.described_square_mm:g} mm ({check.square_residual_pct:+.1f} %): check the "
                "board description (square size) or the calibration's scale")
    return None
