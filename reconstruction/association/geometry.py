"""Closed-form ray geometry for association: pixels -> world rays, two-ray and many-ray midpoints.

All functions are plain array maths on whole clips (no per-frame loops). Units: world mm, image px.
Rays are unit directions in world coordinates starting at the camera centre.
"""

from __future__ import annotations

import numpy as np
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.distortion import undistort_step

UNDISTORT_ITERS = 10
_EPS = 1e-9


def undistort_normalized(xy_d: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """Invert OpenCV distortion (k1, k2, p1, p2, k3) by fixed-point iteration.

    Args:
        xy_d: (..., 2) distorted normalised image coordinates.
        dist: (5,) distortion coefficients.
    Returns:
        (..., 2) undistorted normalised coordinates.
    """
    if not np.any(dist):
        return xy_d
    x0, y0 = xy_d[..., 0], xy_d[..., 1]
    x, y = x0, y0
    for _ in range(UNDISTORT_ITERS):
        x, y = undistort_step(x, y, x0, y0, *dist)
    return np.stack([x, y], axis=-1)


def pixel_rays(rig: Rig, pixels_px: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World rays through pixels.

    Args:
        rig: C cameras, in the order of the first axis of ``pixels_px``.
        pixels_px: (C, ..., 2) px (NaN allowed; NaN rays come out).
    Returns:
        origins_mm (C, 3) camera centres and directions (C, ..., 3) unit vectors in world coordinates.
    """
    dirs = []
    for cam, px in zip(rig.cameras, pixels_px, strict=True):
        k = cam.matrix_px
        y = (px[..., 1] - k[1, 2]) / k[1, 1]
        x = (px[..., 0] - k[0, 2] - k[0, 1] * y) / k[0, 0]
        xy = undistort_normalized(np.stack([x, y], -1), cam.dist)
        ray_cam = np.concatenate([xy, np.ones_like(xy[..., :1])], -1)
        ray = ray_cam @ cam.rotation  # R^T applied to row vectors
        dirs.append(ray / np.linalg.norm(ray, axis=-1, keepdims=True))
    origins = np.stack([cam.center_mm for cam in rig.cameras])
    return origins, np.stack(dirs)


def two_ray_closest(
    sep2: np.ndarray, d1w: np.ndarray, d2w: np.ndarray, dot12: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Closest approach of rays o1 + s d1 and o2 + u d2 (unit directions), from scalar products.

    Args (broadcastable to one shape):
        sep2: |o1 - o2|^2 (mm^2).
        d1w: d1 . (o1 - o2) (mm).
        d2w: d2 . (o1 - o2) (mm).
        dot12: d1 . d2.
    Returns:
        s, u: distances along each ray (mm; > 0 in front of the camera), and the gap between the two
        closest points (mm).
    """
    denom = np.maximum(1.0 - dot12 * dot12, _EPS)
    s = (dot12 * d2w - d1w) / denom
    u = (d2w - dot12 * d1w) / denom
    gap2 = sep2 + s * s + u * u + 2 * s * d1w - 2 * u * d2w - 2 * s * u * dot12
    return s, u, np.sqrt(np.maximum(gap2, 0.0))


def triangulate_rays(
    origins_mm: np.ndarray, directions: np.ndarray, weights: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Weighted least-squares intersection of rays (the point nearest all rays), closed form.

    Args:
        origins_mm: (N, 3) ray origins.
        directions: (B, N, J, 3) unit directions (NaN where absent).
        weights: (B, K, N, J) non-negative weights of ray n for point (b, k, j); 0 drops the ray.
    Returns:
        points_mm (B, K, J, 3), NaN where the rays do not fix a point (fewer than two non-parallel
        rays); and the weight sum (B, K, J).
    """
    d = np.nan_to_num(directions)
    b_, n_, j_, _ = d.shape
    eye = np.eye(3)
    m = eye - d[..., :, None] * d[..., None, :]  # (B, N, J, 3, 3)
    mo = np.einsum("bnjxy,ny->bnjx", m, origins_mm)  # (B, N, J, 3)
    k_ = weights.shape[1]
    w = weights.transpose(0, 3, 1, 2).reshape(b_, j_, k_, n_)  # (B, J, K, N)
    a = np.matmul(w, m.transpose(0, 2, 1, 3, 4).reshape(b_, j_, n_, 9)).reshape(b_, j_, k_, 3, 3)
    rhs = np.matmul(w, mo.transpose(0, 2, 1, 3)).reshape(b_, j_, k_, 3)
    points, det = _solve3(a, rhs)
    wsum = w.sum(-1)
    ok = (det > 1e-6 * np.maximum(wsum, 1.0) ** 3) & (wsum > 0)
    points = np.where(ok[..., None], points, np.nan)
    return points.transpose(0, 2, 1, 3), wsum.transpose(0, 2, 1)


def ray_distance(origins_mm: np.ndarray, directions: np.ndarray, points_mm: np.ndarray) -> np.ndarray:
    """Distance (mm) of points from rays, one point per ray.

    Args:
        origins_mm: (N, 3); directions: (B, N, J, 3) unit; points_mm: (B, N, J, 3) (NaN allowed).
    Returns:
        (B, N, J) distances (NaN where the ray or the point is NaN).
    """
    rel = points_mm - origins_mm[None, :, None, :]
    along = (rel * directions).sum(-1, keepdims=True)
    return np.linalg.norm(rel - along * directions, axis=-1)


def _solve3(a: np.ndarray, rhs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Solve symmetric 3x3 systems a x = rhs by cofactors: a (..., 3, 3), rhs (..., 3)."""
    c00 = a[..., 1, 1] * a[..., 2, 2] - a[..., 1, 2] * a[..., 2, 1]
    c01 = a[..., 1, 2] * a[..., 2, 0] - a[..., 1, 0] * a[..., 2, 2]
    c02 = a[..., 1, 0] * a[..., 2, 1] - a[..., 1, 1] * a[..., 2, 0]
    c11 = a[..., 0, 0] * a[..., 2, 2] - a[..., 0, 2] * a[..., 2, 0]
    c12 = a[..., 0, 1] * a[..., 2, 0] - a[..., 0, 0] * a[..., 2, 1]
    c22 = a[..., 0, 0] * a[..., 1, 1] - a[..., 0, 1] * a[..., 1, 0]
    det = a[..., 0, 0] * c00 + a[..., 0, 1] * c01 + a[..., 0, 2] * c02
    safe = np.where(np.abs(det) > 0, det, 1.0)
    r0, r1, r2 = rhs[..., 0], rhs[..., 1], rhs[..., 2]
    x = (c00 * r0 + c01 * r1 + c02 * r2) / safe
    y = (c01 * r0 + c11 * r1 + c12 * r2) / safe
    z = (c02 * r0 + c12 * r1 + c22 * r2) / safe
    return np.stack([x, y, z], -1), det
