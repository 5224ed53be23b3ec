"""The world frame: a board laid flat on the floor defines the origin and the axes (z up).

World axes from the floor board: x along the board's columns, y = -(board rows), z = -(board normal),
so z points up out of the printed face; the origin is the board's corner 0. A plain checkerboard looks
the same turned by 180 degrees, so its x axis is taken to point away from the first camera (ChArUco
boards fix the axes themselves). The board's pose is averaged
over the static frames at the start (the board lies still while the recording starts). A final guard
turns the world over when the cameras would end up below the floor (the mirrored/flipped-board trap).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.calibration.geometry import mean_rotation, rodrigues_batch, rotation_angle_deg

log = logging.getLogger(__name__)

BOARD_TO_WORLD_AXES = np.diag([1.0, -1.0, -1.0])  # X_board = F X_world (self-inverse)


@dataclass(frozen=True)
class WorldFrameConfig:
    """Which frames show the board on the floor.

    Attributes:
        floor_frame: index of a frame where the board lies on the floor; None = the first frame in
            which the board was seen.
        static_mm / static_deg: following frames whose board pose stays this close count as the same
            floor pose and are averaged.
        plane_deg / plane_mm: every board pose this close to the floor board's plane (the board laid
            down again elsewhere) joins a plane fit that sets the floor's tilt.
    """

    floor_frame: int | None = None
    static_mm: float = 5.0
    static_deg: float = 0.5
    plane_deg: float = 3.0
    plane_mm: float = 30.0


@dataclass(frozen=True, eq=False)
class WorldTransform:
    """World -> old frame: X_old = rotation @ X_world + tvec_mm, plus how it was found."""

    rotation: np.ndarray
    tvec_mm: np.ndarray
    floor_frames: int
    flipped: bool


def floor_pose(
    frame_rotation: np.ndarray, frame_tvec_mm: np.ndarray, used: np.ndarray, config: WorldFrameConfig
) -> tuple[np.ndarray, np.ndarray, int]:
    """Average board -> frame pose over the static floor frames; returns (R, t, frames averaged)."""
    used_idx = np.flatnonzero(used)
    if len(used_idx) == 0:
        raise ValueError("world frame: no board pose was recovered")
    first = int(used_idx[0]) if config.floor_frame is None else int(config.floor_frame)
    if not (0 <= first < len(used) and used[first]):
        raise ValueError(
            f"world frame: frame {first} (floor_frame) has no board pose; pick a frame where the board "
            "lies on the floor and at least one camera sees it"
        )
    frames = [first]
    for f in range(first + 1, len(used)):
        near = np.linalg.norm(frame_tvec_mm[f] - frame_tvec_mm[first]) < config.static_mm
        if not (used[f] and near and rotation_angle_deg(frame_rotation[f], frame_rotation[first]) < config.static_deg):
            break
        frames.append(f)
    return mean_rotation(frame_rotation[frames]), frame_tvec_mm[frames].mean(0), len(frames)


def floor_plane(
    board_rotation: np.ndarray, board_tvec_mm: np.ndarray, frame_rotation: np.ndarray, frame_tvec_mm: np.ndarray,
    used: np.ndarray, object_points_mm: np.ndarray, config: WorldFrameConfig,
) -> tuple[np.ndarray, np.ndarray, int]:
    """Tilt the floor board's pose onto the plane fitted to the corners of every board pose lying in
    its plane (frames (F, 3, 3), (F, 3)); returns the new pose and the number of frames in the fit."""
    normal = board_rotation[:, 2]
    with np.errstate(invalid="ignore"):
        cos = np.clip(frame_rotation[:, :, 2] @ normal, -1.0, 1.0)
        flat = used & (np.degrees(np.arccos(np.nan_to_num(cos))) < config.plane_deg)
        flat &= np.abs((np.nan_to_num(frame_tvec_mm) - board_tvec_mm) @ normal) < config.plane_mm
    pts = (np.einsum("fij,nj->fni", frame_rotation[flat], object_points_mm) + frame_tvec_mm[flat, None]).reshape(-1, 3)
    if len(pts) < 3:
        return board_rotation, board_tvec_mm, int(flat.sum())
    centre = pts.mean(0)
    fitted = np.linalg.svd(pts - centre)[2][-1]
    fitted = fitted if fitted @ normal > 0 else -fitted
    axis = np.cross(normal, fitted)
    angle = np.arctan2(np.linalg.norm(axis), normal @ fitted)
    turn = rodrigues_batch(axis / max(np.linalg.norm(axis), 1e-12) * angle) if angle > 0 else np.eye(3)
    origin = board_tvec_mm - ((board_tvec_mm - centre) @ fitted) * fitted
    return turn @ board_rotation, origin, int(flat.sum())


def world_from_floor(
    board_rotation: np.ndarray, board_tvec_mm: np.ndarray, cam_rotation: np.ndarray, cam_tvec_mm: np.ndarray,
    *, floor_frames: int = 1, symmetric_extent_mm: np.ndarray | None = None,
) -> WorldTransform:
    """World -> old-frame transform from the floor board's pose (board -> old frame).

    ``symmetric_extent_mm`` (2,): the board looks the same turned by 180 degrees (plain checkerboard), and
    this is the x, y span of its corners. Its x axis can then point either way along the board; the one
    pointing away from the first camera is chosen (the origin moves to the opposite corner).
    """
    rot = board_rotation @ BOARD_TO_WORLD_AXES
    centres_old = -np.einsum("cji,cj->ci", cam_rotation, cam_tvec_mm)  # camera centres in the old frame
    if symmetric_extent_mm is not None:
        extent = np.array([symmetric_extent_mm[0], symmetric_extent_mm[1], 0.0])
        middle = board_tvec_mm + board_rotation @ (extent / 2)
        if (middle - centres_old[0]) @ rot[:, 0] < 0:
            board_tvec_mm = board_tvec_mm + board_rotation @ extent
            rot = rot @ np.diag([-1.0, -1.0, 1.0])
    heights = (centres_old - board_tvec_mm) @ rot[:, 2]
    flipped = bool(np.median(heights) < 0)
    if flipped:
        log.warning("world frame: the cameras were below the floor board; turning the world over (z up)")
        rot = rot @ BOARD_TO_WORLD_AXES
    return WorldTransform(rot, np.asarray(board_tvec_mm, dtype=np.float64), floor_frames, flipped)


def to_world(world: WorldTransform, cam_rotation: np.ndarray, cam_tvec_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Camera extrinsics (C, 3, 3), (C, 3) from the old frame to the world frame."""
    rot = cam_rotation @ world.rotation
    tvec = np.einsum("cij,j->ci", cam_rotation, world.tvec_mm) + cam_tvec_mm
    return rot, tvec
