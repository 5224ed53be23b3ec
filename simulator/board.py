"""A calibration board moving through the synthetic room: ground-truth poses, corner observations with
pixel noise, and (for short clips) rendered camera images that the real detector must find.

The clip starts with the board lying still on the floor (its corner 0 at ``floor_origin_mm``, face up,
columns along world x): that is what defines the world frame, so a calibration recovered from these
observations can be compared to the room's true rig directly. Then the board is carried through the
capture volume, turning to face every camera, tilted, sometimes held upside down.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from gaitcap.acquisition.boards.detection import Board
from gaitcap.reconstruction.calibration.geometry import BoardGeometry, BoardObservations
from gaitcap.reconstruction.camera import Rig
from gaitcap.simulator.board_render import BoardRenderer, camera_at
from gaitcap.simulator.room import visible as lens_visible

FLOOR_ROTATION = np.diag([1.0, -1.0, -1.0])  # board -> world for a board lying face up
FLOOR_SPOTS_MM = ((1500.0, 1500.0), (-1500.0, 1200.0), (1000.0, -1500.0))  # where to lay it down again


@dataclass(frozen=True)
class BoardMotion:
    """How the board moves.

    Attributes:
        n_frames: frames in the clip (including the floor frames).
        fps: frame rate (frame times are n / fps s).
        floor_frames: frames at the start with the board lying still on the floor.
        floor_origin_mm: world position of the floor board's corner 0.
        tour_fraction: share of the moving frames spent showing the board to each camera in turn, near
            enough to fill 25-60 % of its image width (good intrinsics); the rest wanders through the
            middle of the room where several cameras see it at once (good extrinsics).
        centre_mm / half_extent_mm: box (mm) that the wandering board's centre stays in.
        turns: full turns of the wandering board's facing direction (so every camera sees it).
        max_tilt_deg: tilt of the board's normal away from facing, deg.
        tour_tilt_deg: the same while it is shown to one camera up close (strong perspective pins down
            the focal length of long lenses).
        max_roll_deg: in-plane rotation, deg.
        upside_down_fraction: share of frames with the board held upside down (180 deg roll).
        floor_spots_mm: after the first floor frames, the board lies still (turned at random) at these
            (x, y) floor positions for floor_frames // 2 frames each (a better floor plane).
        seed: random seed.
    """

    n_frames: int = 600
    fps: float = 10.0
    floor_frames: int = 20
    floor_origin_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    tour_fraction: float = 0.5
    centre_mm: tuple[float, float, float] = (0.0, 0.0, 1100.0)
    half_extent_mm: tuple[float, float, float] = (2000.0, 2000.0, 500.0)
    turns: float = 3.0
    max_tilt_deg: float = 35.0
    tour_tilt_deg: float = 50.0
    max_roll_deg: float = 30.0
    upside_down_fraction: float = 0.2
    floor_spots_mm: tuple[tuple[float, float], ...] = ()
    seed: int = 0


def _rot(axis: int, angle: np.ndarray) -> np.ndarray:
    """Rotations (F, 3, 3) about a fixed axis by angles (F,) rad."""
    c, s = np.cos(angle), np.sin(angle)
    out = np.tile(np.eye(3), (len(angle), 1, 1))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    out[:, i, i], out[:, j, j], out[:, i, j], out[:, j, i] = c, c, -s, s
    return out


def _smooth_noise(rng: np.random.Generator, n: int, knots: int) -> np.ndarray:
    """Smooth random curve (n,) in [-1, 1] through ``knots`` random values."""
    xk = np.linspace(0, n - 1, max(knots, 2))
    return np.interp(np.arange(n), xk, rng.uniform(-1, 1, max(knots, 2)))


def _facing(normal: np.ndarray) -> np.ndarray:
    """Board -> world rotations (F, 3, 3) with the printed face towards ``normal`` (F, 3), rows downwards."""
    z = -normal / np.linalg.norm(normal, axis=1, keepdims=True)
    down = np.array([0.0, 0.0, -1.0])
    y = down - (z @ down)[:, None] * z
    y /= np.linalg.norm(y, axis=1, keepdims=True)
    x = np.cross(y, z)
    return np.stack([x, y, z], axis=2)


def _tilt_noise(rng, n: int, up_close: np.ndarray) -> np.ndarray:
    """Tilt curve (n,) in [-1, 1]: turning every second or so, and every few frames while the board is
    shown to one camera up close (varied tilts there are what pin down that camera's intrinsics)."""
    return np.where(up_close, _smooth_noise(rng, n, max(4, n // 3)), _smooth_noise(rng, n, max(4, n // 10)))


def _hand_motion(rng, motion: BoardMotion, n: int, tilt_deg: np.ndarray, up_close: np.ndarray) -> np.ndarray:
    """Tilt (up to ``tilt_deg`` (n,)) and roll (F, 3, 3), applied in the board frame; sometimes upside down."""
    knots = max(4, n // 10)
    tilt = np.radians(tilt_deg)
    roll = np.radians(motion.max_roll_deg) * _smooth_noise(rng, n, knots)
    roll += np.pi * (_smooth_noise(rng, n, knots) > 1 - 2 * motion.upside_down_fraction)
    return (_rot(0, tilt * _tilt_noise(rng, n, up_close)) @ _rot(1, tilt * _tilt_noise(rng, n, up_close))
            @ _rot(2, roll))


def _tour(rng, rig: Rig, geometry: BoardGeometry, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Board centres (n, 3) and face normals (n, 3): each camera in turn sees the board up close."""
    width = np.ptp(geometry.object_points_mm[:, 0]) + 2 * geometry.square_mm
    centres, normals = [], []
    for cam, idx in zip(rig, np.array_split(np.arange(n), len(rig)), strict=True):
        m = len(idx)
        fx, (w, h) = cam.matrix_px[0, 0], cam.size_px
        frac = 0.425 + 0.175 * _smooth_noise(rng, m, 3)  # board spans 25-60 % of the image width
        dist = np.maximum(fx * width / (frac * w), 1000.0)
        a = 0.45 * (w / 2) / fx * _smooth_noise(rng, m, 5)
        b = 0.45 * (h / 2) / fx * _smooth_noise(rng, m, 5)
        rows = cam.rotation
        ray = rows[2] + a[:, None] * rows[0] + b[:, None] * rows[1]
        ray /= np.linalg.norm(ray, axis=1, keepdims=True)
        centres.append(cam.center_mm + dist[:, None] * ray)
        normals.append(-ray)
    return np.concatenate(centres), np.concatenate(normals)


def _wander(rng, motion: BoardMotion, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Board centres (n, 3) and face normals (n, 3) wandering through the middle of the room."""
    knots = max(4, n // 12)
    centre = np.asarray(motion.centre_mm) + np.stack(
        [h * _smooth_noise(rng, n, knots) for h in motion.half_extent_mm], axis=1
    )
    facing = 2 * np.pi * motion.turns * np.arange(n) / max(n, 1) + rng.uniform(0, 2 * np.pi)
    return centre, np.stack([np.cos(facing), np.sin(facing), np.zeros(n)], axis=1)


def board_trajectory(geometry: BoardGeometry, motion: BoardMotion, rig: Rig | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Board -> world poses: rotations (F, 3, 3), translations (F, 3) mm. Without a rig, no tour."""
    rng = np.random.default_rng(motion.seed)
    n_move = motion.n_frames - motion.floor_frames
    if n_move < 1 or motion.floor_frames < 0:
        raise ValueError(f"board motion: n_frames ({motion.n_frames}) must exceed floor_frames ({motion.floor_frames})")
    n_tour = int(round(motion.tour_fraction * n_move)) if rig is not None else 0
    parts = [_tour(rng, rig, geometry, n_tour)] if n_tour else []
    parts.append(_wander(rng, motion, n_move - n_tour))
    centre = np.concatenate([p[0] for p in parts])
    up_close = np.arange(n_move) < n_tour
    tilt = np.where(up_close, motion.tour_tilt_deg, motion.max_tilt_deg)
    rot = _facing(np.concatenate([p[1] for p in parts])) @ _hand_motion(rng, motion, n_move, tilt, up_close)
    tvec = centre - rot @ geometry.object_points_mm.mean(0)
    floor_r = [np.tile(FLOOR_ROTATION, (motion.floor_frames, 1, 1))]
    floor_t = [np.tile(np.asarray(motion.floor_origin_mm, dtype=np.float64), (motion.floor_frames, 1))]
    for spot in motion.floor_spots_mm:  # laid down again elsewhere, turned, for half as long
        n = max(motion.floor_frames // 2, 1)
        floor_r.append(np.tile(_rot(2, rng.uniform(-np.pi, np.pi, 1))[0] @ FLOOR_ROTATION, (n, 1, 1)))
        floor_t.append(np.tile([spot[0], spot[1], 0.0], (n, 1)))
    n_floor = sum(len(r) for r in floor_r)
    rot, tvec = rot[: len(rot) - n_floor + motion.floor_frames], tvec[: len(tvec) - n_floor + motion.floor_frames]
    return np.concatenate([floor_r[0], *floor_r[1:], rot]), np.concatenate([floor_t[0], *floor_t[1:], tvec])


def _visible_views(rig: Rig, geometry: BoardGeometry, rot: np.ndarray, tvec: np.ndarray, max_angle_deg: float):
    """(C, F) bool: the camera faces the printed side at less than ``max_angle_deg`` from its normal."""
    centre = rot @ geometry.object_points_mm.mean(0) + tvec  # (F, 3)
    front = -rot[:, :, 2]  # printed face normal in the world
    out = []
    for cam in rig:
        ray = cam.center_mm - centre
        cos = np.einsum("fi,fi->f", ray, front) / np.linalg.norm(ray, axis=1)
        out.append(cos > np.cos(np.radians(max_angle_deg)))
    return np.array(out)


def observe_board(
    rig: Rig, geometry: BoardGeometry, rot: np.ndarray, tvec: np.ndarray, *, noise_px: float = 0.5,
    max_angle_deg: float = 70.0, margin_px: float = 5.0, scramble: bool = False, fps: float = 10.0, seed: int = 0,
    still_floor: bool = False, readout_s: float = 0.0,
) -> BoardObservations:
    """Project the board's corners into every camera with Gaussian pixel noise (per axis, px).

    ``readout_s``: a rolling shutter reads the image's rows out one after another over this time (s), so
    a corner in row y is seen ``readout_s * y / height`` after the frame's time, where the moving board
    has gone on (the corners between two frames are interpolated linearly): a moving board comes out
    skewed, as webcams show it.
    Views that show the board's back or too obliquely are dropped; a board that needs all its corners
    (plain checkerboard) is dropped when any corner leaves the image. ``scramble`` reports each view's
    corners in a random order among the board's symmetries (as an orientation-blind detector would),
    except in the floor frames at the start. ``still_floor``: the floor frames are one still scene, so
    every camera's corner errors repeat in all of them (as a detector's do on a static image).
    """
    rng = np.random.default_rng(seed)
    world = np.einsum("fij,nj->fni", rot, geometry.object_points_mm) + tvec[:, None]  # (F, N, 3)
    visible = _visible_views(rig, geometry, rot, tvec, max_angle_deg)
    corners = np.full((len(rig), len(rot), geometry.num_corners, 2), np.nan)
    syms = np.asarray(geometry.symmetries)
    floor = np.isclose(rot[:, 2, 2], -1.0) & np.isclose(tvec[:, 2], 0.0)  # lying face up on the floor
    for c, cam in enumerate(rig):
        px, ok = _rolling_shutter(cam, world, readout_s * fps, margin_px)
        noise = rng.normal(0, noise_px, px.shape)
        for f in np.flatnonzero(floor) if still_floor else ():  # one still scene per floor spot
            same = np.flatnonzero(floor & np.all(np.isclose(tvec, tvec[f]), axis=1))
            noise[f] = noise[same[0]]
        px = px + noise
        ok &= cam.in_image(px, margin_px=-margin_px) & visible[c][:, None]
        if geometry.min_corners >= geometry.num_corners:
            ok &= ok.all(axis=1, keepdims=True)
        ok &= ok.sum(axis=1, keepdims=True) >= geometry.min_corners
        corners[c][ok] = px[ok]
        if scramble:
            for f in np.flatnonzero(ok.any(1) & ~floor):
                corners[c, f] = corners[c, f][syms[rng.integers(len(syms))]]
    times = np.arange(len(rot)) / fps
    return BoardObservations(tuple(rig.names), tuple(c.size_px for c in rig), corners, geometry, times)


def _rolling_shutter(cam, world: np.ndarray, readout_frames: float, margin_px: float):
    """Corners (F, N, 2) px as a rolling shutter sees world points (F, N, 3) mm moving from frame to frame
    (``readout_frames``: the readout time in frame intervals), and which are visible."""
    px, ok = lens_visible(cam, world, margin_px=-margin_px)
    if readout_frames <= 0:
        return px, ok
    step = np.concatenate([np.diff(world, axis=0), np.zeros_like(world[:1])])  # to the next frame, mm
    for _ in range(2):  # a corner's row sets its time, its time sets its row: two passes converge
        lag = readout_frames * np.clip(np.nan_to_num(px[..., 1:2]) / cam.size_px[1], 0.0, 1.0)
        px, ok = lens_visible(cam, world + lag * step, margin_px=-margin_px)
    return px, ok


def scaled_rig(rig: Rig, scale: float) -> Rig:
    """The same rig imaged at ``scale`` x the resolution (matches :func:`render_board_images`)."""
    return Rig(tuple(camera_at(cam, scale) for cam in rig))


def write_board_folder(folder: str | os.PathLike, images: dict[str, np.ndarray]) -> Path:
    """Write rendered images as ``FOLDER/<camera>/000000.png`` (the folder input of ``gaitcap calibrate``)."""
    folder = Path(folder)
    for cam, frames in images.items():
        (folder / cam).mkdir(parents=True, exist_ok=True)
        for i, img in enumerate(frames):
            if not cv2.imwrite(str(folder / cam / f"{i:06d}.png"), img):
                raise ValueError(f"could not write {folder / cam / f'{i:06d}.png'}")
    return folder


def write_board_mcap(path: str | os.PathLike, images: dict[str, np.ndarray], *, fps: float = 10.0,
                     start_ns: int = 1_700_000_000_000_000_000) -> Path:
    """Write rendered images as a trial MCAP (JPEG frames, synchronised frame ids), like the recorder."""
    from gaitcap.acquisition.encoding import encode_jpeg
    from gaitcap.acquisition.recording.writer import TrialWriter

    writer = TrialWriter(path)
    writer.start(metadata={"kind": "calibration", "synthetic": True}, time_ns=start_ns)
    n = min(len(v) for v in images.values())
    for i in range(n):
        stamp = start_ns + int(round(i * 1e9 / fps))
        for cam, frames in images.items():
            add_jpeg_frame(writer, cam, encode_jpeg(frames[i], quality=95), frame_id=i, stamp_ns=stamp)
    return writer.finish({"frames": n, "cameras": sorted(images)})


def add_jpeg_frame(writer, camera: str, jpeg: bytes, *, frame_id: int, stamp_ns: int) -> None:
    """One camera's JPEG frame into a trial writer, stamped as a synchronised rig would (ns)."""
    from gaitcap.acquisition.encoding import image_message

    msg = image_message(jpeg, camera=camera, timestamp_ns=stamp_ns)
    writer.add_frame(camera, msg, timestamp_ns=stamp_ns, frame_id=frame_id, receive_ns=stamp_ns)


def render_board_images(
    rig: Rig, board: Board, rot: np.ndarray, tvec: np.ndarray, *, scale: float = 0.25, supersample: int = 2,
    noise_gray: float = 2.0, background: int = 110, seed: int = 0,
) -> dict[str, np.ndarray]:
    """Grey images {camera: (F, H, W) uint8} of the board at poses (rot, tvec) (F, 3, 3), (F, 3) mm, at
    ``scale`` x the cameras' resolution (use :func:`scaled_rig` for the matching intrinsics), with
    Gaussian grey-level noise. An opaque board shows a blank back."""
    rng = np.random.default_rng(seed)
    out = {}
    for cam in rig:
        renderer = BoardRenderer(cam, board, size_px=camera_at(cam, scale).size_px, supersample=supersample,
                                 noise_gray=noise_gray, background=background)
        w, h = renderer.size_px
        frames = np.empty((len(rot), h, w), dtype=np.uint8)
        for i, (r_b, t_b) in enumerate(zip(rot, tvec, strict=True)):
            frames[i] = renderer.render(r_b, t_b, rng)
        out[cam.name] = frames
    return out
