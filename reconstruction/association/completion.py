"""Track completion: detections the per-frame association left out, given to the track they continue.

A frame alone cannot always tell who is who: when two people cross in a camera's view, a pair of views
whose rays do not agree (a mirrored or partly occluded detection) or a person seen by two cameras only
at the start of a clip leaves a tracked person without detections for a few frames. Over time it can:
each track's association joints are predicted where it is not seen (linear interpolation between the
frames where it is, held at its ends; at most ``max_gap_s`` from a sighting) and where it is; every detection left
unassigned is compared with every track's prediction by reprojection (the per-frame association's cost:
median error over the box diagonal, left/right mirrored detections recognised), and given, one per
track and camera, to the track it fits best within ``reprojection_gate``. A track gains a frame only
when at least ``min_views`` cameras see it there; its joints are triangulated again from the completed
detections. Detections already assigned keep their track.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from gaitcap.reconstruction.association.config import AssociationConfig
from gaitcap.reconstruction.association.rays import Rays, make_rays, quiet_warnings
from gaitcap.reconstruction.association.refine import (
    ROBUST_ITERS,
    assign_greedy,
    of_group,
    reprojection_cost,
    triangulate_groups,
)
from gaitcap.reconstruction.association.tracking import Tracks
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints

__all__ = ["complete_tracks", "predicted_points"]


def predicted_points(points_mm: np.ndarray, times_s: np.ndarray, *, max_gap_s: float) -> np.ndarray:
    """Each track's joints at every frame -> (M, T, Ja, 3) mm.

    Where a track is seen, its own joints; between sightings, linear interpolation in time (per joint
    and axis); before its first and after its last sighting, the nearest sighting held. Frames farther
    than ``max_gap_s`` from the nearest sighting of that joint stay NaN.
    """
    out = np.full_like(points_mm, np.nan)
    m_, _, ja, _ = points_mm.shape
    for m in range(m_):
        for j in range(ja):
            seen = np.flatnonzero(np.isfinite(points_mm[m, :, j]).all(-1))
            if seen.size == 0:
                continue
            near = _distance_to_nearest(times_s, times_s[seen]) <= max_gap_s  # (T,)
            for a in range(3):
                out[m, near, j, a] = np.interp(times_s[near], times_s[seen], points_mm[m, seen, j, a])
    return out


def _distance_to_nearest(times_s: np.ndarray, sightings_s: np.ndarray) -> np.ndarray:
    """(T,) time (s) from each frame to the nearest of the sorted ``sightings_s``."""
    at = np.searchsorted(sightings_s, times_s)
    before = sightings_s[np.clip(at - 1, 0, len(sightings_s) - 1)]
    after = sightings_s[np.clip(at, 0, len(sightings_s) - 1)]
    return np.minimum(np.abs(times_s - before), np.abs(after - times_s))


def complete_tracks(multi: MultiViewKeypoints, rig: Rig, tracks: Tracks, config: AssociationConfig, *,
                    max_gap_s: float) -> Tracks:
    """Give unassigned detections to the tracks they continue (see the module docstring). Only frames
    with an unassigned detection are looked at."""
    m_ = tracks.num_tracks
    if m_ == 0:
        return tracks
    rig = rig.subset(multi.camera_names)
    rays = make_rays(multi, rig, tracks.joint_indices, config)
    old = tracks.detection_track
    frames = np.flatnonzero(((old < 0) & rays.mask.any(-1)).any(axis=(0, 2)))
    if frames.size == 0:
        return tracks
    rays = _at_frames(rays, frames)
    pred = predicted_points(tracks.points_mm, tracks.times_s, max_gap_s=max_gap_s)[:, frames]  # (M, F, Ja, 3)
    cost, flipped = reprojection_cost(rig, rays, pred.transpose(1, 0, 2, 3), config)  # (C, F, P, M)
    before = old[:, frames]
    mine = before[..., None] == np.arange(m_)  # (C, F, P, M)
    cost = np.where((before >= 0)[..., None] | mine.any(2, keepdims=True), np.inf, cost)  # one per camera
    new = assign_greedy(cost)
    after = np.where(before >= 0, before, new)
    views = (after[..., None] == np.arange(m_)).any(2).sum(0).T  # (M, F)
    gained = (views >= config.min_views) & (views > tracks.views[:, frames])
    take = (new >= 0) & (before < 0) & gained.T[np.arange(len(frames))[None, :, None], np.maximum(new, 0)]
    if not take.any():
        return tracks
    after = np.where(take, new, before)
    c_, f_, p_ = after.shape
    groups = after.transpose(1, 0, 2).reshape(f_, c_ * p_)
    mirrored = np.where(take, of_group(flipped, groups), tracks.mirrored()[:, frames])
    points = triangulate_groups(rays, groups, flipped=mirrored, num_groups=m_,
                                robust_iters=ROBUST_ITERS).transpose(1, 0, 2, 3)  # (M, F, Ja, 3)
    grown = ((after[..., None] == np.arange(m_)) & take[..., None]).any(axis=(0, 2)).T  # (M, F)
    return _with_frames(tracks, frames, grown, after, mirrored, points)


def _at_frames(rays: Rays, frames: np.ndarray) -> Rays:
    """``rays`` of the given frames only."""
    return dataclasses.replace(rays, dirs=rays.dirs[:, frames], mask=rays.mask[:, frames],
                               pixels_px=rays.pixels_px[:, frames], scale_px=rays.scale_px[:, frames])


def _with_frames(tracks: Tracks, frames: np.ndarray, grown: np.ndarray, detection_track: np.ndarray,
                 mirrored: np.ndarray, points_mm: np.ndarray) -> Tracks:
    """``tracks`` with ``frames``' detections, flags and, for the tracks ``grown`` (M, F) there, points
    (M, F, Ja, 3) mm, roots and views replaced."""
    m_ = tracks.num_tracks
    det, flip = tracks.detection_track.copy(), tracks.mirrored().copy()
    det[:, frames], flip[:, frames] = detection_track, mirrored
    points, views, root = tracks.points_mm.copy(), tracks.views.copy(), tracks.root_mm.copy()
    new_views = (detection_track[..., None] == np.arange(m_)).any(2).sum(0).T  # (M, F)
    points[:, frames] = np.where(grown[..., None, None], points_mm, points[:, frames])
    views[:, frames] = np.where(grown, new_views, views[:, frames])
    with quiet_warnings():
        root[:, frames] = np.where(grown[..., None], np.nanmean(points_mm, axis=2), root[:, frames])
    return dataclasses.replace(tracks, detection_track=det, points_mm=points, views=views, root_mm=root,
                               flipped=flip)
