"""The camera rig of the synthetic room: N cameras around the walls aimed at the diagonal walkway.

Like the paper's lab: FLIR BlackFly S (1920 x 1200 px, 5.86 um pixels) with 6 mm lenses (fx ~ 1024 px,
86 x 60 degree field of view) and 12 mm lenses (fx ~ 2048 px), only the first radial distortion term k1,
mounted 2.0-2.5 m high on the walls. Cameras are spread evenly around the perimeter; each aims at the part
of the walkway in front of it, and the far-looking ones get the 12 mm lens.
"""

from __future__ import annotations

import math

import numpy as np
from gaitcap.reconstruction.camera import Camera, Rig, matrix_to_rodrigues
from gaitcap.simulator.path import Room

SENSOR_PX = (1920, 1200)
PIXEL_MM = 0.00586
WALL_INSET_MM = 150.0


def camera_name(i: int) -> str:
    return f"cam{i + 1:02d}"


def look_at(center_mm: np.ndarray, target_mm: np.ndarray, roll_rad: float = 0.0) -> np.ndarray:
    """World -> camera rotation for a camera at ``center_mm`` looking at ``target_mm`` (z up, no roll)."""
    z = np.asarray(target_mm, float) - np.asarray(center_mm, float)
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    if np.linalg.norm(x) < 1e-9:
        x = np.array([1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    r = np.stack([x, y, z])  # rows: camera axes in world coordinates (x right, y down, z forward)
    if roll_rad:
        c, s = math.cos(roll_rad), math.sin(roll_rad)
        r = np.array([[c, s, 0], [-s, c, 0], [0, 0, 1.0]]) @ r
    return r


def _perimeter_point(u: float, room: Room) -> tuple[np.ndarray, np.ndarray]:
    """Point at fraction u of the (inset) perimeter, counter-clockwise from corner A, and the inward normal."""
    hx, hy = room.half - WALL_INSET_MM
    sides = [2 * hx, 2 * hy, 2 * hx, 2 * hy]
    total = sum(sides)
    d = (u % 1.0) * total
    corners = [np.array([-hx, -hy]), np.array([hx, -hy]), np.array([hx, hy]), np.array([-hx, hy])]
    normals = [np.array([0, 1.0]), np.array([-1.0, 0]), np.array([0, -1.0]), np.array([1.0, 0])]
    for i, length in enumerate(sides):
        if d <= length:
            a, b = corners[i], corners[(i + 1) % 4]
            return a + (b - a) * (d / length), normals[i]
        d -= length
    return corners[0], normals[0]


def build_rig(
    n_cameras: int = 10,
    seed: int = 0,
    room: Room | None = None,
    walkway_margin_mm: float = 1400.0,
) -> Rig:
    """A rig of ``n_cameras`` named cam01.. around the room (deterministic given the seed)."""
    if int(n_cameras) != n_cameras or n_cameras < 2:
        raise ValueError(f"cameras must be an integer >= 2, got {n_cameras}")
    if n_cameras > 32:
        raise ValueError(f"cameras must be <= 32, got {n_cameras}")
    room = room or Room()
    rng = np.random.default_rng([int(seed), 7301])
    a, b = room.corner_a, room.corner_b
    diag = b - a
    dlen = float(np.linalg.norm(diag))
    d = diag / dlen
    cams = []
    # offset so that no camera sits exactly in a walkway corner (a frontal view at 1.4 m is useless)
    offset = 0.5 / n_cameras + 0.03
    for i in range(n_cameras):
        u = offset + i / n_cameras + rng.uniform(-0.01, 0.01)
        pos_xy, inward = _perimeter_point(u, room)
        height = rng.uniform(2000.0, 2500.0)
        center = np.array([pos_xy[0], pos_xy[1], height])
        # aim at the walkway point closest to the camera, kept within the central part of the walk
        s = float(np.clip((pos_xy - a) @ d, walkway_margin_mm + 1500.0, dlen - walkway_margin_mm - 1500.0))
        target_xy = a + s * d
        target = np.array([target_xy[0], target_xy[1], rng.uniform(700.0, 1000.0)])
        dist = float(np.linalg.norm(target - center))
        far = dist > 4300.0
        f_mm = (12.0 if far else 6.0) * rng.uniform(0.99, 1.01)
        fx = f_mm / PIXEL_MM
        k = np.array([
            [fx, 0.0, SENSOR_PX[0] / 2 + rng.normal(0, 8)],
            [0.0, fx * rng.uniform(0.999, 1.001), SENSOR_PX[1] / 2 + rng.normal(0, 8)],
            [0.0, 0.0, 1.0],
        ])
        k1 = rng.uniform(-0.25, -0.10) if far else rng.uniform(-0.10, -0.05)
        r = look_at(center, target, roll_rad=rng.normal(0, 0.01))
        t = -r @ center
        cams.append(
            Camera(
                name=camera_name(i), size_px=SENSOR_PX, matrix_px=k, dist=np.array([k1, 0, 0, 0, 0]),
                rvec=matrix_to_rodrigues(r), tvec_mm=t, serial=f"SYN{int(seed) % 10000:04d}{i + 1:02d}",
            )
        )
    return Rig(tuple(cams))


def visible(cam: Camera, points_mm: np.ndarray, margin_px: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Distorted pixels (..., 2) and a mask (...,) of points in front of the camera and inside the image.

    Points outside the lens' valid field of view are rejected before distortion (with k1 < 0 the radial
    model folds far-off-axis points back into the image).
    """
    pc = cam.to_camera(points_mm)
    z = pc[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        xy = pc[..., :2] / z[..., None]
    k = cam.matrix_px
    r2_max = np.inf
    k1 = cam.dist[0]
    if k1 < 0:
        r2_max = -1.0 / (3.0 * k1) * 0.95
    r2 = (xy**2).sum(-1)
    ok = (z > 100.0) & (r2 < r2_max)
    xy = np.where(ok[..., None], xy, 0.0)
    px = cam.distort_normalized(xy) @ k[:2, :2].T + k[:2, 2]
    ok &= cam.in_image(px, margin_px=margin_px)
    return px, ok


def safe_project(cam: Camera, points_mm: np.ndarray) -> np.ndarray:
    """Like ``cam.project`` but monotone beyond the lens' valid field (for drawing partly visible things).

    With k1 < 0 the radial model r (1 + k1 r^2) turns back at r^2 = -1 / (3 k1); past 95 % of that radius
    the distorted radius continues linearly, so off-image points stay off the image. Points behind the
    camera come out NaN.
    """
    pc = cam.to_camera(points_mm)
    z = pc[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        xy = pc[..., :2] / z[..., None]
    k1 = cam.dist[0]
    if k1 >= 0 or np.any(cam.dist[1:] != 0):
        px = cam.distort_normalized(xy) @ cam.matrix_px[:2, :2].T + cam.matrix_px[:2, 2]
    else:
        r = np.linalg.norm(xy, axis=-1)
        r_m = math.sqrt(-1.0 / (3.0 * k1) * 0.95)
        slope = 1 + 3 * k1 * r_m**2
        rd = np.where(r <= r_m, r * (1 + k1 * r**2), r_m * (1 + k1 * r_m**2) + slope * (r - r_m))
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(r > 1e-12, rd / r, 1.0)
        px = (xy * scale[..., None]) @ cam.matrix_px[:2, :2].T + cam.matrix_px[:2, 2]
    return np.where((z > 1.0)[..., None], px, np.nan)
