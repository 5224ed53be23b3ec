"""Pinhole camera with OpenCV distortion, and a rig of cameras (NumPy reference model).

Conventions (used everywhere in gaitcap):
- World points in mm; image points in px; ``x_cam = R @ X_world + t`` with ``R`` from the Rodrigues
  vector ``rvec`` (world -> camera) and ``t = tvec_mm``.
- Distortion follows OpenCV's (k1, k2, p1, p2, k3) model; the paper's rig keeps only k1.
- Image size is (width, height) in px.

The JAX versions used for fitting live in :mod:`gaitcap.reconstruction.projection`; this module is the plain
NumPy model used for I/O, validation and as a reference in tests.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field

import numpy as np
from gaitcap.reconstruction.distortion import distort

ORTHONORMAL_TOL = 1e-6


def rodrigues_to_matrix(rvec: np.ndarray) -> np.ndarray:
    """Rotation vector (3,) in rad -> rotation matrix (3, 3)."""
    rvec = np.asarray(rvec, dtype=np.float64).reshape(3)
    theta = float(np.linalg.norm(rvec))
    if theta < 1e-12:
        return np.eye(3)
    k = rvec / theta
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(theta) * kx + (1 - np.cos(theta)) * (kx @ kx)


def matrix_to_rodrigues(rmat: np.ndarray) -> np.ndarray:
    """Rotation matrix (3, 3) -> rotation vector (3,) in rad. Raises if not a rotation."""
    rmat = np.asarray(rmat, dtype=np.float64)
    check_rotation(rmat, what="rotation")
    cos = np.clip((np.trace(rmat) - 1) / 2, -1.0, 1.0)
    theta = float(np.arccos(cos))
    if theta < 1e-12:
        return np.zeros(3)
    if np.pi - theta < 1e-6:
        # Near 180 deg: axis from the symmetric part.
        b = (rmat + np.eye(3)) / 2
        axis = np.sqrt(np.clip(np.diag(b), 0, None))
        i = int(np.argmax(axis))
        axis = b[i] / np.sqrt(b[i, i])
        return axis / np.linalg.norm(axis) * theta
    w = np.array([rmat[2, 1] - rmat[1, 2], rmat[0, 2] - rmat[2, 0], rmat[1, 0] - rmat[0, 1]])
    return w / (2 * np.sin(theta)) * theta


def check_rotation(rmat: np.ndarray, *, what: str) -> None:
    """Raise ValueError naming ``what`` unless ``rmat`` is a proper 3x3 rotation."""
    if rmat.shape != (3, 3):
        raise ValueError(f"{what}: expected a 3x3 rotation matrix, got shape {rmat.shape}")
    err = float(np.abs(rmat @ rmat.T - np.eye(3)).max())
    if err > ORTHONORMAL_TOL or np.linalg.det(rmat) < 0:
        raise ValueError(
            f"{what}: rotation matrix is not orthonormal with det +1 (max |R R^T - I| = {err:.2e}, "
            f"det = {np.linalg.det(rmat):.4f})"
        )


def _as_array(value, shape: tuple[int, ...], *, what: str) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != shape:
        raise ValueError(f"{what}: expected shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{what}: contains NaN or infinite values")
    return arr


@dataclass(frozen=True, eq=False)
class Camera:
    """One calibrated camera.

    Attributes:
        name: unique name in the rig (used to match detections and recordings).
        size_px: (width, height) of the image in px.
        matrix_px: intrinsics K (3, 3) in px.
        dist: OpenCV distortion (5,): k1, k2, p1, p2, k3 (dimensionless).
        rvec: Rodrigues rotation world -> camera (3,), rad.
        tvec_mm: translation world -> camera (3,), mm.
        serial: hardware serial number (FLIR cameras), may be empty.
    """

    name: str
    size_px: tuple[int, int]
    matrix_px: np.ndarray
    dist: np.ndarray = field(default_factory=lambda: np.zeros(5))
    rvec: np.ndarray = field(default_factory=lambda: np.zeros(3))
    tvec_mm: np.ndarray = field(default_factory=lambda: np.zeros(3))
    serial: str = ""

    def __post_init__(self) -> None:
        what = f"camera {self.name!r}"
        if not isinstance(self.name, str) or not self.name:
            raise ValueError("camera: name must be a non-empty string")
        size = tuple(int(v) for v in np.asarray(self.size_px).reshape(-1))
        if len(size) != 2 or min(size) <= 0:
            raise ValueError(f"{what}: size_px must be (width, height) > 0, got {self.size_px}")
        object.__setattr__(self, "size_px", size)
        k = _as_array(self.matrix_px, (3, 3), what=f"{what} matrix_px")
        if k[0, 0] <= 0 or k[1, 1] <= 0 or not np.allclose(k[2], [0, 0, 1]):
            raise ValueError(f"{what} matrix_px: expected fx, fy > 0 and last row [0, 0, 1]")
        object.__setattr__(self, "matrix_px", k)
        dist = np.asarray(self.dist, dtype=np.float64).reshape(-1)
        if dist.size > 5 or dist.size == 0:
            raise ValueError(f"{what} dist: expected 1 to 5 coefficients (k1, k2, p1, p2, k3), got {dist.size}")
        object.__setattr__(self, "dist", _as_array(np.pad(dist, (0, 5 - dist.size)), (5,), what=f"{what} dist"))
        object.__setattr__(self, "rvec", _as_array(self.rvec, (3,), what=f"{what} rvec"))
        object.__setattr__(self, "tvec_mm", _as_array(self.tvec_mm, (3,), what=f"{what} tvec_mm"))

    @property
    def rotation(self) -> np.ndarray:
        """World -> camera rotation matrix (3, 3)."""
        return rodrigues_to_matrix(self.rvec)

    @property
    def center_mm(self) -> np.ndarray:
        """Camera centre in world coordinates (3,), mm."""
        return -self.rotation.T @ self.tvec_mm

    @property
    def extrinsics(self) -> np.ndarray:
        """[R | t] (3, 4), t in mm."""
        return np.hstack([self.rotation, self.tvec_mm[:, None]])

    @property
    def projection_px(self) -> np.ndarray:
        """Undistorted projection matrix K [R | t] (3, 4): px per mm-homogeneous point."""
        return self.matrix_px @ self.extrinsics

    def to_camera(self, points_mm: np.ndarray) -> np.ndarray:
        """World points (..., 3) mm -> camera-frame points (..., 3) mm."""
        return np.asarray(points_mm) @ self.rotation.T + self.tvec_mm

    def project(self, points_mm: np.ndarray) -> np.ndarray:
        """Project world points (..., 3) mm to distorted pixels (..., 2) px (OpenCV model)."""
        pc = self.to_camera(points_mm)
        xy = pc[..., :2] / pc[..., 2:3]
        return self.distort_normalized(xy) @ self.matrix_px[:2, :2].T + self.matrix_px[:2, 2]

    def distort_normalized(self, xy: np.ndarray) -> np.ndarray:
        """Apply OpenCV distortion to normalised image coordinates (..., 2)."""
        return np.stack(distort(xy[..., 0], xy[..., 1], *self.dist), axis=-1)

    def depth_mm(self, points_mm: np.ndarray) -> np.ndarray:
        """Depth along the optical axis (...,) mm; <= 0 means behind the camera."""
        return self.to_camera(points_mm)[..., 2]

    def in_image(self, pixels_px: np.ndarray, margin_px: float = 0.0) -> np.ndarray:
        """Boolean mask (...,) of pixels inside the image (with an optional margin)."""
        w, h = self.size_px
        x, y = pixels_px[..., 0], pixels_px[..., 1]
        return (x >= -margin_px) & (y >= -margin_px) & (x < w + margin_px) & (y < h + margin_px)

    def replace(self, **changes) -> Camera:
        """A copy with some fields changed."""
        values = {f: getattr(self, f) for f in self.__dataclass_fields__}
        values.update(changes)
        return Camera(**values)


@dataclass(frozen=True, eq=False)
class Rig:
    """An ordered set of cameras with unique names."""

    cameras: tuple[Camera, ...]

    def __post_init__(self) -> None:
        cams = tuple(self.cameras)
        if not cams:
            raise ValueError("rig: needs at least one camera")
        names = [c.name for c in cams]
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            raise ValueError(f"rig: duplicate camera names {dupes}")
        object.__setattr__(self, "cameras", cams)

    def __len__(self) -> int:
        return len(self.cameras)

    def __iter__(self) -> Iterator[Camera]:
        return iter(self.cameras)

    def __getitem__(self, key: int | str) -> Camera:
        if isinstance(key, str):
            return self.camera(key)
        return self.cameras[key]

    @property
    def names(self) -> list[str]:
        return [c.name for c in self.cameras]

    def camera(self, name: str) -> Camera:
        for cam in self.cameras:
            if cam.name == name:
                return cam
        raise KeyError(f"camera {name!r} is not in the rig (rig has {self.names})")

    def index_of(self, names: Iterable[str]) -> list[int]:
        """Indices of the given camera names; ValueError naming any that are missing."""
        names = list(names)
        missing = [n for n in names if n not in self.names]
        if missing:
            raise ValueError(f"cameras {missing} are not in the calibration (it has {self.names})")
        return [self.names.index(n) for n in names]

    def subset(self, names: Iterable[str]) -> Rig:
        return Rig(tuple(self.cameras[i] for i in self.index_of(names)))

    def stacked(self) -> dict[str, np.ndarray]:
        """Arrays for vectorised maths: K (C,3,3) px, dist (C,5), R (C,3,3), t_mm (C,3), P (C,3,4)."""
        return {
            "K": np.stack([c.matrix_px for c in self.cameras]),
            "dist": np.stack([c.dist for c in self.cameras]),
            "R": np.stack([c.rotation for c in self.cameras]),
            "t_mm": np.stack([c.tvec_mm for c in self.cameras]),
            "P": np.stack([c.projection_px for c in self.cameras]),
        }

    def project(self, points_mm: np.ndarray) -> np.ndarray:
        """Project world points (..., 3) mm through every camera -> (C, ..., 2) px."""
        return np.stack([c.project(points_mm) for c in self.cameras])
