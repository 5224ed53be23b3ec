"""Board geometry, board observations and small rigid-transform helpers for calibration.

A board is a planar grid of corners in its own frame (z = 0, mm): x along the columns, y along the
rows, so the board's z axis points INTO the printed face (away from a viewer who sees the print).
Observations are dense: ``corners_px (C, F, N, 2)`` with NaN where camera c did not see corner n of
the board in frame f.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np


@dataclass(frozen=True, eq=False)
class BoardGeometry:
    """A planar calibration target.

    Attributes:
        name: human-readable description (e.g. "checkerboard 7x5 squares of 110 mm").
        object_points_mm: (N, 3) corner positions in the board frame, z = 0, mm.
        square_mm: side of one square, mm.
        neighbours: (E, 2) corner-index pairs that are one square apart (for the scale check).
        symmetries: corner-index permutations a detector may confuse with the true order
            (identity first). ``perm[i]`` is the true corner id of the detector's corner ``i``.
        min_corners: fewest corners that make a usable view.
    """

    name: str
    object_points_mm: np.ndarray
    square_mm: float
    neighbours: np.ndarray
    symmetries: tuple[tuple[int, ...], ...]
    min_corners: int

    def __post_init__(self) -> None:
        pts = np.asarray(self.object_points_mm, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) < 4:
            raise ValueError(f"board {self.name}: object_points_mm must be (N>=4, 3), got {pts.shape}")
        if not np.allclose(pts[:, 2], 0):
            raise ValueError(f"board {self.name}: object points must be planar (z = 0)")
        n = len(pts)
        for perm in self.symmetries:
            if sorted(perm) != list(range(n)):
                raise ValueError(f"board {self.name}: a symmetry is not a permutation of {n} corners")
        if not self.symmetries or list(self.symmetries[0]) != list(range(n)):
            raise ValueError(f"board {self.name}: the first symmetry must be the identity")
        object.__setattr__(self, "object_points_mm", pts)
        object.__setattr__(self, "neighbours", np.asarray(self.neighbours, dtype=np.int64).reshape(-1, 2))

    @property
    def num_corners(self) -> int:
        return len(self.object_points_mm)


def grid_board(
    name: str, *, corners_x: int, corners_y: int, square_mm: float, mirror_ambiguous: bool, min_corners: int
) -> BoardGeometry:
    """A rectangular grid of ``corners_x * corners_y`` corners, row-major (index = row * corners_x + col).

    ``mirror_ambiguous``: the detector cannot tell the board's orientation (plain checkerboard), so the
    180-degree rotation and both mirror orders are listed as symmetries.
    """
    if corners_x < 2 or corners_y < 2 or square_mm <= 0:
        raise ValueError(f"board {name}: needs at least 2x2 corners and square_mm > 0")
    if mirror_ambiguous and corners_x == corners_y:
        raise ValueError(f"board {name}: a square corner grid is ambiguous under 90 deg; use unequal sides")
    yy, xx = np.mgrid[0:corners_y, 0:corners_x]
    pts = np.stack([xx.ravel() * square_mm, yy.ravel() * square_mm, np.zeros(xx.size)], axis=1)
    idx = np.arange(xx.size).reshape(corners_y, corners_x)
    pairs = [np.stack([idx[:, :-1].ravel(), idx[:, 1:].ravel()], 1), np.stack([idx[:-1].ravel(), idx[1:].ravel()], 1)]
    syms = [tuple(idx.ravel().tolist())]
    if mirror_ambiguous:
        syms += [tuple(idx[::-1, ::-1].ravel().tolist()), tuple(idx[:, ::-1].ravel().tolist()),
                 tuple(idx[::-1, :].ravel().tolist())]
    return BoardGeometry(name, pts, float(square_mm), np.concatenate(pairs), tuple(syms), min_corners)


@dataclass(frozen=True, eq=False)
class BoardObservations:
    """Board corners seen by C cameras over F synchronised frames.

    Attributes:
        camera_names: (C,) names.
        image_sizes_px: (C,) (width, height) px.
        corners_px: (C, F, N, 2) px, NaN where not seen; corner order as reported by the detector.
        board: the board's geometry (N corners).
        times_s: (F,) frame times in s (default: frame index).
    """

    camera_names: tuple[str, ...]
    image_sizes_px: tuple[tuple[int, int], ...]
    corners_px: np.ndarray
    board: BoardGeometry
    times_s: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self) -> None:
        names = tuple(str(n) for n in self.camera_names)
        corners = np.asarray(self.corners_px, dtype=np.float64)
        if corners.ndim != 4 or corners.shape[-1] != 2:
            raise ValueError(f"corners_px: expected shape (C, F, N, 2), got {corners.shape}")
        c, f, n, _ = corners.shape
        if len(names) != c or len(set(names)) != c:
            raise ValueError(f"camera_names: need {c} unique names, got {list(names)}")
        if n != self.board.num_corners:
            raise ValueError(
                f"corners_px has {n} corners per view but board {self.board.name} has "
                f"{self.board.num_corners}: wrong board size given?"
            )
        sizes = tuple((int(w), int(h)) for w, h in self.image_sizes_px)
        if len(sizes) != c:
            raise ValueError(f"image_sizes_px: {len(sizes)} sizes for {c} cameras")
        times = np.asarray(self.times_s, dtype=np.float64).reshape(-1)
        if times.size == 0:
            times = np.arange(f, dtype=np.float64)
        if times.shape != (f,):
            raise ValueError(f"times_s: expected {f} times, got {times.size}")
        object.__setattr__(self, "camera_names", names)
        object.__setattr__(self, "image_sizes_px", sizes)
        object.__setattr__(self, "corners_px", corners)
        object.__setattr__(self, "times_s", times)

    @property
    def shape(self) -> tuple[int, int, int]:
        """(C, F, N)."""
        c, f, n, _ = self.corners_px.shape
        return c, f, n

    def seen(self) -> np.ndarray:
        """(C, F, N) bool: corner observed."""
        return np.all(np.isfinite(self.corners_px), axis=-1)

    def views(self) -> np.ndarray:
        """(C, F) bool: a usable view (at least ``board.min_corners`` corners)."""
        return self.seen().sum(-1) >= self.board.min_corners


# --- rigid transforms -------------------------------------------------------------------------------


def rodrigues_batch(rvecs: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3) rad -> matrices (..., 3, 3)."""
    rvecs = np.asarray(rvecs, dtype=np.float64)
    theta = np.linalg.norm(rvecs, axis=-1)[..., None, None]
    safe = np.where(theta < 1e-12, 1.0, theta)
    k = rvecs / safe[..., 0]
    zero = np.zeros(k.shape[:-1])
    kx = np.stack(
        [np.stack([zero, -k[..., 2], k[..., 1]], -1), np.stack([k[..., 2], zero, -k[..., 0]], -1),
         np.stack([-k[..., 1], k[..., 0], zero], -1)], -2,
    )
    eye = np.broadcast_to(np.eye(3), kx.shape)
    return eye + np.sin(theta) * kx + (1 - np.cos(theta)) * (kx @ kx)


def rvec_of(rmat: np.ndarray) -> np.ndarray:
    """Rotation matrix (3, 3) -> Rodrigues vector (3,)."""
    return cv2.Rodrigues(np.asarray(rmat, dtype=np.float64))[0].ravel()


def rotation_angle_deg(r_a: np.ndarray, r_b: np.ndarray) -> np.ndarray:
    """Angle (...,) in degrees of the rotation r_a r_b^T for stacks of matrices (..., 3, 3)."""
    cos = (np.trace(r_a @ np.swapaxes(r_b, -1, -2), axis1=-2, axis2=-1) - 1) / 2
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def mean_rotation(rmats: np.ndarray) -> np.ndarray:
    """Chordal L2 mean of rotation matrices (K, 3, 3) -> (3, 3)."""
    u, _, vt = np.linalg.svd(np.sum(rmats, axis=0))
    d = np.sign(np.linalg.det(u @ vt))
    return u @ np.diag([1.0, 1.0, d]) @ vt


def invert(rmat: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of x' = R x + t."""
    return rmat.T, -rmat.T @ t


def compose(r_a: np.ndarray, t_a: np.ndarray, r_b: np.ndarray, t_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(A o B): x -> R_a (R_b x + t_b) + t_a."""
    return r_a @ r_b, r_a @ t_b + t_a
