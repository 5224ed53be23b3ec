"""Frame rendering of the synthetic world for the simulated camera driver.

The room (floor with a 0.5 m grid, the walkway mat along the diagonal, walls) is ray-cast once per camera
and image size through the full camera model (distortion included) and cached. People are drawn on top
as shaded capsules (limbs, trunk) and spheres (head), far to near (painter's algorithm), with radii from
the projected depth. Images are BGR uint8 (OpenCV order), (H, W, 3).

The camera is scaled to the requested size like a resize of the full sensor image: fx, cx by W / width,
fy, cy by H / height (so a 640 x 480 render of a 1920 x 1200 camera has non-square pixels, as a resized
frame would).
"""

from __future__ import annotations

import functools
import math

import cv2
import numpy as np
from gaitcap.reconstruction.camera import Camera
from gaitcap.reconstruction.skeletons import get_skeleton
from gaitcap.simulator.room import safe_project

SKELETON = get_skeleton("halpe26")
J = SKELETON.index

# BGR colours
_FLOOR = np.array([150, 160, 168], float)
_GRID = np.array([120, 128, 135], float)
_MAT = np.array([70, 60, 55], float)
_WALL = np.array([205, 210, 214], float)
_CEIL = np.array([230, 232, 234], float)
_SKIN = (120, 160, 210)
_OUTFITS = (
    ((190, 120, 50), (70, 60, 55)),  # patient: blue shirt, dark trousers
    ((60, 140, 60), (200, 200, 200)),  # therapist: green top, light trousers
    ((60, 60, 170), (90, 80, 50)),  # bystander: red top
)

# (joint a, joint b, radius as a fraction of body height, part) for the capsules
_PARTS = (
    ("left_hip", "left_knee", 0.040, "legs"), ("right_hip", "right_knee", 0.040, "legs"),
    ("left_knee", "left_ankle", 0.030, "legs"), ("right_knee", "right_ankle", 0.030, "legs"),
    ("left_ankle", "left_big_toe", 0.022, "shoe"), ("right_ankle", "right_big_toe", 0.022, "shoe"),
    ("left_heel", "left_big_toe", 0.020, "shoe"), ("right_heel", "right_big_toe", 0.020, "shoe"),
    ("left_hip", "right_hip", 0.055, "legs"),
    ("pelvis", "neck", 0.075, "top"),
    ("left_shoulder", "right_shoulder", 0.040, "top"), ("left_hip", "left_shoulder", 0.05, "top"),
    ("right_hip", "right_shoulder", 0.05, "top"),
    ("left_shoulder", "left_elbow", 0.025, "top"), ("right_shoulder", "right_elbow", 0.025, "top"),
    ("left_elbow", "left_wrist", 0.020, "skin"), ("right_elbow", "right_wrist", 0.020, "skin"),
    ("neck", "nose", 0.028, "skin"),
)


def scaled_camera(cam: Camera, size_px: tuple[int, int]) -> Camera:
    """The camera as seen in an image resized from its sensor size to ``size_px`` (width, height)."""
    w, h = (int(v) for v in size_px)
    if w <= 0 or h <= 0:
        raise ValueError(f"size_px must be positive (width, height), got {size_px}")
    sx, sy = w / cam.size_px[0], h / cam.size_px[1]
    k = cam.matrix_px.copy()
    k[0] *= sx
    k[1] *= sy
    return cam.replace(size_px=(w, h), matrix_px=k)


def _cam_key(cam: Camera) -> tuple:
    return (cam.size_px, tuple(cam.matrix_px.ravel()), tuple(cam.dist), tuple(cam.rvec), tuple(cam.tvec_mm))


@functools.lru_cache(maxsize=64)
def _background_cached(key: tuple, room_half: tuple[float, float], height_mm: float) -> np.ndarray:
    (w, h), kflat, dist, rvec, tvec = key
    cam = Camera("bg", (w, h), np.array(kflat).reshape(3, 3), np.array(dist), np.array(rvec), np.array(tvec))
    u, v = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    pix = np.stack([u.ravel(), v.ravel()], -1).astype(np.float64)
    norm = cv2.undistortPoints(pix[:, None, :], cam.matrix_px, cam.dist).reshape(-1, 2)
    rays_c = np.concatenate([norm, np.ones((norm.shape[0], 1))], -1)
    r = cam.rotation
    rays = rays_c @ r  # world directions (R^T d)
    c = cam.center_mm
    hx, hy = room_half
    big = 1e12
    # distance along the ray to each surface (floor, ceiling, 4 walls)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_floor = np.where(rays[:, 2] < 0, -c[2] / rays[:, 2], big)
        t_ceil = np.where(rays[:, 2] > 0, (height_mm - c[2]) / rays[:, 2], big)
        t_wx = np.where(rays[:, 0] > 0, (hx - c[0]) / rays[:, 0], np.where(rays[:, 0] < 0, (-hx - c[0]) / rays[:, 0], big))
        t_wy = np.where(rays[:, 1] > 0, (hy - c[1]) / rays[:, 1], np.where(rays[:, 1] < 0, (-hy - c[1]) / rays[:, 1], big))
    ts = np.stack([t_floor, t_ceil, t_wx, t_wy], -1)
    which = np.argmin(ts, -1)
    t = ts[np.arange(ts.shape[0]), which]
    hit = c + rays * t[:, None]
    img = np.empty((hit.shape[0], 3))
    floor = which == 0
    # floor: grid every 500 mm, the walkway mat along the diagonal
    x, y = hit[:, 0], hit[:, 1]
    grid = (np.abs((x + 250) % 500 - 250) < 8) | (np.abs((y + 250) % 500 - 250) < 8)
    d = np.array([hx, hy]) / math.hypot(hx, hy)
    across = np.abs(-d[1] * x + d[0] * y)
    along = np.abs(d[0] * x + d[1] * y)
    mat = (across < 450) & (along < math.hypot(hx, hy) - 1500)
    img[floor] = np.where(grid[floor, None], _GRID, _FLOOR)
    img[floor & mat] = _MAT
    img[which == 1] = _CEIL
    walls = (which == 2) | (which == 3)
    shade = np.where(which == 2, 1.0, 0.92)[:, None]
    skirting = hit[:, 2] < 100
    img[walls] = (_WALL * shade[walls])
    img[walls & skirting] = _WALL * 0.6
    # soft distance falloff
    dist_m = t / 1000.0
    img *= np.clip(1.1 - 0.03 * dist_m, 0.6, 1.0)[:, None]
    return np.clip(img, 0, 255).astype(np.uint8).reshape(h, w, 3)


def background(cam: Camera, room_half=(3700.0, 4000.0), height_mm: float = 3000.0) -> np.ndarray:
    """The empty room from ``cam`` (cached; a copy is returned)."""
    return _background_cached(_cam_key(cam), tuple(float(v) for v in room_half), float(height_mm)).copy()


_PART_A = np.array([J(a) for a, _, _, _ in _PARTS])
_PART_B = np.array([J(b) for _, b, _, _ in _PARTS])
_PART_RADIUS = np.array([rad for _, _, rad, _ in _PARTS])  # fraction of body height
_PART_KIND = tuple(part for _, _, _, part in _PARTS)
# shading layers (fraction of the radius, brightness), outer to inner; light from the upper left
_CAPSULE_LAYERS = np.array([(1.0, 0.55), (0.75, 0.8), (0.45, 1.0), (0.18, 1.2)])
_SPHERE_LAYERS = np.array([(1.0, 0.6), (0.8, 0.8), (0.5, 1.0), (0.2, 1.25)])
_LIGHT = {"capsule": -0.25, "sphere": -0.3}  # offset of the highlight, fraction of the radius


@functools.lru_cache(maxsize=256)
def _shade(color: tuple, f: float) -> tuple:
    return tuple(int(min(255, max(0, c * f))) for c in color)


def _draw_person(img, cam: Camera, pts: np.ndarray, height_mm: float, outfit) -> list:
    """Drawing commands (depth mm, kind, a px, b px, radius px, colour) for one person."""
    depth = cam.depth_mm(pts)
    px = safe_project(cam, pts)
    f = 0.5 * (cam.matrix_px[0, 0] + cam.matrix_px[1, 1])
    top, legs = outfit
    colors = {"top": top, "legs": legs, "skin": _SKIN, "shoe": (40, 40, 40)}
    za, zb = depth[_PART_A], depth[_PART_B]
    pa, pb = px[_PART_A], px[_PART_B]
    ok = ~((za < 150) | (zb < 150)) & np.isfinite(pa).all(-1) & np.isfinite(pb).all(-1)
    z = 0.5 * (za + zb)
    r_px = f * _PART_RADIUS * height_mm / z
    cmds = [(z[i], "capsule", pa[i], pb[i], r_px[i], colors[_PART_KIND[i]]) for i in np.flatnonzero(ok)]
    # head sphere centred between the ears, slightly up
    hc = 0.5 * (pts[J("left_ear")] + pts[J("right_ear")]) + np.array([0, 0, 0.01 * height_mm])
    zc = float(cam.depth_mm(hc))
    if zc > 150:
        cmds.append((zc - 1.0, "sphere", safe_project(cam, hc), None, f * 0.062 * height_mm / zc, _SKIN))
    return cmds


def _layer_geometry(cmds, w: int, h: int) -> tuple[list, list]:
    """Per command (in order) and shading layer: the shape's end points shifted towards the light (int px;
    a sphere's centre twice) and its line thickness / circle radius (px), as lists for OpenCV."""
    lim = 4 * max(w, h)
    capsule = np.array([kind == "capsule" for _, kind, *_ in cmds])
    ends = np.array([(pa, pa if pb is None else pb) for _, _, pa, pb, _, _ in cmds], dtype=np.float64)  # (N, 2, 2)
    r = np.minimum(np.array([c[4] for c in cmds], dtype=np.float64), 2 * max(w, h))
    frac = np.where(capsule[:, None], _CAPSULE_LAYERS[:, 0], _SPHERE_LAYERS[:, 0])  # (N, 4)
    light = np.where(capsule, _LIGHT["capsule"], _LIGHT["sphere"])
    o = light[:, None] * r[:, None] * (1 - frac)  # (N, 4) the same shift along x and y
    shifted = np.rint(np.clip(ends, -lim, lim)[:, :, None, :] + o[:, None, :, None]).astype(np.int64)
    size = np.where(capsule[:, None], 2 * r[:, None] * frac, r[:, None] * frac)
    return shifted.tolist(), np.maximum(1, np.rint(size)).astype(np.int64).tolist()


def _execute(img, cmds) -> None:
    """Draw the commands far to near (painter's algorithm), each as layers from dark rim to bright core."""
    if not cmds:
        return
    h, w = img.shape[:2]
    cmds = sorted(cmds, key=lambda c: -c[0])
    ends, sizes = _layer_geometry(cmds, w, h)
    capsule_bright, sphere_bright = _CAPSULE_LAYERS[:, 1].tolist(), _SPHERE_LAYERS[:, 1].tolist()
    for (_, kind, _, _, _, color), (a, b), size in zip(cmds, ends, sizes, strict=True):
        if kind == "capsule":
            for k, bright in enumerate(capsule_bright):
                cv2.line(img, a[k], b[k], _shade(color, bright), size[k], cv2.LINE_AA)
        else:
            for k, bright in enumerate(sphere_bright):
                cv2.circle(img, a[k], size[k], _shade(color, bright), -1, cv2.LINE_AA)


def _people_at(trial, frame_index: int):
    pts = trial.all_points_mm[:, frame_index]  # (P, J, 3)
    heights = [trial.body.height] + [float(np.ptp(p[..., 2])) + 0.02 * trial.body.height for p in pts[1:]]
    return pts, heights


@functools.lru_cache(maxsize=64)
def _view(cam_key: tuple, size_px: tuple[int, int], room_half: tuple[float, float]) -> tuple[Camera, np.ndarray]:
    """A rig camera (by :func:`_cam_key`) scaled to ``size_px`` and its empty room (read-only), made once."""
    full_size, kflat, dist, rvec, tvec = cam_key
    cam = scaled_camera(Camera("view", full_size, np.array(kflat).reshape(3, 3), np.array(dist), np.array(rvec),
                               np.array(tvec)), size_px)
    room = _background_cached(_cam_key(cam), room_half, 3000.0)  # the cached room itself, not a second copy
    room.flags.writeable = False
    return cam, room


def render_frame(trial, camera_index: int, frame_index: int, size_px: tuple[int, int] = (640, 480)) -> np.ndarray:
    """(H, W, 3) uint8 BGR image of frame ``frame_index`` seen by rig camera ``camera_index``."""
    n_frames = trial.times_s.shape[0]
    if not 0 <= frame_index < n_frames:
        raise ValueError(f"frame_index {frame_index} outside the trial's {n_frames} frames")
    if not 0 <= camera_index < len(trial.rig):
        raise ValueError(f"camera_index {camera_index} outside the rig's {len(trial.rig)} cameras")
    cam, room = _view(_cam_key(trial.rig[camera_index]), tuple(int(v) for v in size_px),
                      tuple(float(v) for v in trial.room.half))
    img = room.copy()
    pts, heights = _people_at(trial, frame_index)
    cmds = []
    for p in range(pts.shape[0]):
        cmds += _draw_person(img, cam, pts[p], heights[p], _OUTFITS[p % len(_OUTFITS)])
    _execute(img, cmds)
    return img
