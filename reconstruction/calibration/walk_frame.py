"""The world frame from a walking trial: the floor plane from the feet in stance, x along the walk.

For rigs calibrated without a floor board (or to check one): reconstruct a walk with the calibration,
then ``world_from_walk`` finds the floor as the plane through the foot points while they stand still
(heels and toes on the ground), z up towards the pelvis, the origin under the middle of the walk, and x along the walking
direction of the first pass. ``reframe_rig`` moves a rig into that frame.
"""

from __future__ import annotations

import numpy as np
from gaitcap.reconstruction.calibration.world import WorldTransform, to_world
from gaitcap.reconstruction.camera import Rig, matrix_to_rodrigues

STILL_SHARE = 0.3
FIRST_PASS_MM = 500.0  # the walking direction is the way the pelvis first moves this far


def _floor_plane(feet: np.ndarray, up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Plane (point, unit normal along ``up``) through the foot points while they stand still (stance:
    the slowest share of each point's frame-to-frame steps), feet: (T, K, 3)."""
    still = []
    for k in range(feet.shape[1]):
        track = feet[:, k]
        step = np.linalg.norm(np.diff(track, axis=0), axis=1)
        ok = np.isfinite(step)
        if ok.sum() < 3:
            continue
        still.append(track[:-1][ok & (step <= np.quantile(step[ok], STILL_SHARE))])
    if not still:
        raise ValueError("world from walk: no foot point was reconstructed in 3 or more frames in a row")
    pts = np.concatenate(still)
    centre = pts.mean(0)
    normal = np.linalg.svd(pts - centre)[2][-1]
    return centre, normal if normal @ up > 0 else -normal


def world_from_walk(feet_mm: np.ndarray, pelvis_mm: np.ndarray, *, foot_height_mm: float = 0.0) -> WorldTransform:
    """World -> calibration-frame transform from a walk.

    feet_mm: (T, K, 3) heel/toe points (NaN where missing); pelvis_mm: (T, 3); foot_height_mm: height of
    those points above the floor when flat on it.
    """
    feet, pelvis = np.asarray(feet_mm, dtype=np.float64), np.asarray(pelvis_mm, dtype=np.float64)
    ok = np.all(np.isfinite(pelvis), axis=1)
    if ok.sum() < 2:
        raise ValueError("world from walk: the pelvis was reconstructed in fewer than 2 frames")
    up = pelvis[ok].mean(0) - np.nanmean(feet.reshape(-1, 3), axis=0)
    if not np.all(np.isfinite(up)) or np.linalg.norm(up) < 1e-6:
        raise ValueError("world from walk: cannot tell up from the feet and the pelvis")
    point, z = _floor_plane(feet, up / np.linalg.norm(up))
    path = pelvis[ok] - (pelvis[ok] @ z)[:, None] * z  # pelvis path on the floor
    centre = path.mean(0)
    direction = np.linalg.svd(path - centre)[2][0]
    away = np.linalg.norm(path - path[0], axis=1)
    first_pass = path[int(np.argmax(away > FIRST_PASS_MM)) if (away > FIRST_PASS_MM).any() else -1] - path[0]
    x = direction if direction @ first_pass >= 0 else -direction
    x = x - (x @ z) * z
    x /= np.linalg.norm(x)
    rot = np.column_stack([x, np.cross(z, x), z])
    origin = centre + ((point - centre) @ z) * z - foot_height_mm * z
    return WorldTransform(rot, origin, floor_frames=0, flipped=False)


def reframe_rig(rig: Rig, world: WorldTransform) -> Rig:
    """The rig with its extrinsics expressed in ``world``'s frame."""
    stacked = rig.stacked()
    rot, tvec = to_world(world, stacked["R"], stacked["t_mm"])
    return Rig(tuple(cam.replace(rvec=matrix_to_rodrigues(r), tvec_mm=t) for cam, r, t in zip(rig, rot, tvec, strict=True)))
