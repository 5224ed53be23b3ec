"""Camera maths in JAX: projection with OpenCV distortion and iterative undistortion.

Layout: cameras FIRST and points flattened, i.e. observations are (C, N) arrays with N = T * J. World
points enter as (3, N) and the rigid transform of every camera is one matmul of a (3C, 3) stack of
rotation rows with the points, so the backward pass is a matmul too (no broadcast of points over a
leading camera axis, which XLA:CPU turns into a slow leading-axis reduction). Camera parameters are
(C, 1) columns broadcast along N.

Units: world points mm, pixels px, normalised image coordinates dimensionless.
The NumPy reference model is :class:`gaitcap.reconstruction.camera.Camera`; tests check both against OpenCV.
"""

from __future__ import annotations

from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from gaitcap.reconstruction import distortion
from gaitcap.reconstruction.camera import Rig

UNDISTORT_ITERS = 20


class CameraArrays(NamedTuple):
    """A rig as arrays (a JAX pytree; pass it to jitted functions as an argument).

    Attributes:
        rot_rows: (3C, 3) rows of R stacked as [R[:, 0, :]; R[:, 1, :]; R[:, 2, :]] (x rows of every
            camera, then y rows, then z rows), world -> camera.
        t_mm: (3C, 1) translations stacked the same way, mm.
        focal_px: (C, 2) fx, fy px.
        center_px: (C, 2) cx, cy px.
        skew_px: (C, 1) K[0, 1] px (0 for almost every camera).
        dist: (C, 5) OpenCV k1, k2, p1, p2, k3.
    """

    rot_rows: jnp.ndarray
    t_mm: jnp.ndarray
    focal_px: jnp.ndarray
    center_px: jnp.ndarray
    skew_px: jnp.ndarray
    dist: jnp.ndarray

    @property
    def num_cameras(self) -> int:
        return self.focal_px.shape[0]


def camera_arrays(rig: Rig, dtype=jnp.float32) -> CameraArrays:
    """Stack a rig's calibration into :class:`CameraArrays`."""
    s = rig.stacked()
    rot = s["R"]  # (C, 3, 3)
    k = s["K"]
    return CameraArrays(
        rot_rows=jnp.asarray(np.concatenate([rot[:, 0, :], rot[:, 1, :], rot[:, 2, :]]), dtype),
        t_mm=jnp.asarray(s["t_mm"].T.reshape(-1, 1), dtype),
        focal_px=jnp.asarray(np.stack([k[:, 0, 0], k[:, 1, 1]], -1), dtype),
        center_px=jnp.asarray(np.stack([k[:, 0, 2], k[:, 1, 2]], -1), dtype),
        skew_px=jnp.asarray(k[:, 0, 1:2], dtype),
        dist=jnp.asarray(s["dist"], dtype),
    )


def to_camera(points_mm: jnp.ndarray, cams: CameraArrays) -> tuple[jnp.ndarray, jnp.ndarray, jnp.ndarray]:
    """World points (3, N) mm -> camera-frame x, y, z, each (C, N) mm."""
    pc = cams.rot_rows @ points_mm + cams.t_mm  # (3C, N)
    c = cams.num_cameras
    return pc[:c], pc[c : 2 * c], pc[2 * c :]


def distort(xn: jnp.ndarray, yn: jnp.ndarray, dist: jnp.ndarray) -> tuple[jnp.ndarray, jnp.ndarray]:
    """OpenCV distortion of normalised coordinates xn, yn (C, N) with dist (C, 5)."""
    return distortion.distort(xn, yn, *(dist[:, i : i + 1] for i in range(5)))


def project(points_mm: jnp.ndarray, cams: CameraArrays) -> tuple[jnp.ndarray, jnp.ndarray]:
    """World points (3, N) mm -> distorted pixels u, v, each (C, N) px.

    Points behind a camera (z <= 0) still give finite numbers; callers mask them if needed.
    """
    x, y, z = to_camera(points_mm, cams)
    z = jnp.where(jnp.abs(z) < 1e-6, 1e-6, z)
    xd, yd = distort(x / z, y / z, cams.dist)
    u = cams.focal_px[:, 0:1] * xd + cams.skew_px * yd + cams.center_px[:, 0:1]
    v = cams.focal_px[:, 1:2] * yd + cams.center_px[:, 1:2]
    return u, v


def project_points(points_mm, cams: CameraArrays) -> jnp.ndarray:
    """Convenience: world points (..., 3) mm -> pixels (C, ..., 2) px."""
    pts = jnp.asarray(points_mm)
    lead = pts.shape[:-1]
    u, v = project(pts.reshape(-1, 3).T, cams)
    return jnp.stack([u, v], -1).reshape((cams.num_cameras, *lead, 2))


def normalize_pixels(u: jnp.ndarray, v: jnp.ndarray, cams: CameraArrays) -> tuple[jnp.ndarray, jnp.ndarray]:
    """Distorted pixels (C, N) -> distorted normalised coordinates (inverse of K only)."""
    yd = (v - cams.center_px[:, 1:2]) / cams.focal_px[:, 1:2]
    xd = (u - cams.center_px[:, 0:1] - cams.skew_px * yd) / cams.focal_px[:, 0:1]
    return xd, yd


@partial(jax.jit, static_argnames=("iters",))
def undistort_normalized(
    xd: jnp.ndarray, yd: jnp.ndarray, dist: jnp.ndarray, iters: int = UNDISTORT_ITERS
) -> tuple[jnp.ndarray, jnp.ndarray]:
    """Invert :func:`distort` by OpenCV's fixed-point iteration (``iters`` steps)."""
    coeffs = tuple(dist[:, i : i + 1] for i in range(5))

    def step(_, xy):
        return distortion.undistort_step(*xy, xd, yd, *coeffs)

    return jax.lax.fori_loop(0, iters, step, (xd, yd))


def undistort_pixels(
    u: jnp.ndarray, v: jnp.ndarray, cams: CameraArrays, iters: int = UNDISTORT_ITERS
) -> tuple[jnp.ndarray, jnp.ndarray]:
    """Distorted pixels u, v (C, N) px -> undistorted normalised coordinates (C, N) (like
    ``cv2.undistortPoints`` without R and P)."""
    xd, yd = normalize_pixels(u, v, cams)
    return undistort_normalized(xd, yd, cams.dist, iters)
