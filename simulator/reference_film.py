"""A reference recording's markers filmed by the simulated rig, for validating gaitcap against it.

The reference's joints (lab frame, its own clock) are moved by a known rigid transform into the room
(z up, floor at 0, on the room's diagonal), sampled at the rig's rate from a known start time, completed
to Halpe-26 (``mocap.halpe26_points``) and detected with detector-like noise (``noise.detect``). The
transform and the start time are what ``gaitcap validate`` must find again.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.validation.align import interp_nan
from gaitcap.reconstruction.validation.reference import Reference, up_axis_of
from gaitcap.simulator.mocap import MocapWalk, film_points, halpe26_points
from gaitcap.simulator.path import Room

_MARKERS = ("hip", "knee", "ankle", "heel", "big_toe")


@dataclass(frozen=True, eq=False)
class FilmedReference:
    """detections, rig; rotation (3, 3) and translation_mm (3,): room = rotation @ lab + translation;
    start_s: reference time of the first frame (the lag: reference time = trial time + start_s);
    times_s (T,) trial frame times from 0; points_mm (T, 26, 3) the filmed joints (room)."""

    detections: MultiViewKeypoints
    rig: object
    rotation: np.ndarray
    translation_mm: np.ndarray
    start_s: float
    times_s: np.ndarray
    points_mm: np.ndarray


def room_transform(ref: Reference, *, yaw_deg: float = 0.0, room: Room | None = None) -> tuple[np.ndarray, np.ndarray]:
    """A rigid transform lab -> room that stands the walk up (z up, floor at 0), sends it along the room's
    diagonal (turned by ``yaw_deg``) and centres it in the room."""
    room = room or Room()
    axis, sign = up_axis_of(ref.joints_mm)
    hips = 0.5 * (ref.joints_mm["left_hip"] + ref.joints_mm["right_hip"])
    ok = np.isfinite(hips).all(axis=1)
    travel = hips[ok][-1] - hips[ok][0]
    up = np.zeros(3)
    up[axis] = sign
    fwd = travel - (travel @ up) * up
    fwd /= np.linalg.norm(fwd)
    lab = np.stack([fwd, np.cross(up, fwd), up])  # rows: forward, left, up in lab coordinates
    d = (room.corner_b - room.corner_a) / room.diagonal_mm
    h = np.arctan2(d[1], d[0]) + np.radians(yaw_deg)
    turn = np.array([[np.cos(h), -np.sin(h), 0.0], [np.sin(h), np.cos(h), 0.0], [0.0, 0.0, 1.0]])
    rot = turn @ lab
    heels = np.concatenate([ref.joints_mm[f"{s}_heel"] for s in ("left", "right")]) @ rot.T
    centre = hips[ok].mean(axis=0) @ rot.T
    return rot, np.array([-centre[0], -centre[1], -np.nanmin(heels[:, 2])])


def film_reference(ref: Reference, *, start_s: float, duration_s: float, fps: float = 30.0, yaw_deg: float = 0.0,
                   preset: str = "paper", cameras: int = 10, seed: int = 0) -> FilmedReference:
    """Film ``ref`` from reference time ``start_s`` for ``duration_s`` at ``fps`` (module docstring)."""
    rot, t = room_transform(ref, yaw_deg=yaw_deg)
    times = np.arange(0.0, duration_s, 1.0 / fps)
    if start_s < 0 or start_s + times[-1] > ref.times_s[-1]:
        raise ValueError(f"start_s: {start_s} + {duration_s} s lies outside the reference's {ref.times_s[-1]:.2f} s")
    markers = {}
    for side in ("left", "right"):
        for j in _MARKERS:
            p = interp_nan(times + start_s, ref.times_s, ref.joints_mm[f"{side}_{j}"])
            markers[f"{side}_{'toe' if j == 'big_toe' else j}"] = p @ rot.T + t
    walk = MocapWalk("reference", ref.source, fps, times, markers, {}, {}, ())
    points = halpe26_points(walk)
    det, rig = film_points(points, times, preset=preset, cameras=cameras, seed=seed,
                           rng=np.random.default_rng([seed, 37]))
    return FilmedReference(det, rig, rot, t, start_s, times, points)
