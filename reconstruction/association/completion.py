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

import numpy as np
from gaitcap.reconstruction.association.config import AssociationConfig
from gaitcap.reconstruction.association.multi import MultiPersonDetections
from gaitcap.reconstruction.association.rays import make_rays, quiet_warnings
from gaitcap.reconstruction.association.refine import (
    ROBUST_ITERS,
    assign_greedy,
    of_group,
    reprojection_cost,
    triangulate_groups,
)
from gaitcap.reconstruction.association.tracking import Tracks
from gaitcap.reconstruction.camera import Rig

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


def complete_tracks(multi: MultiPersonDetections, rig: Rig, tracks: Tracks, config: AssociationConfig, *,
                    max_gap_s: float) -> Tracks:
    """Give unassigned detections to the tracks they continue (see the module docstring)."""
    m_ = tracks.num_tracks
    if m_ == 0:
        return tracks
    rig = rig.subset(multi.camera_names)
    c_, t_, p_, _ = multi.shape
    rays = make_rays(multi, rig, tracks.joint_indices, config)
    pred = predicted_points(tracks.points_mm, tracks.times_s, max_gap_s=max_gap_s)  # (M, T, Ja, 3)
    cost, flipped = reprojection_cost(rig, rays, pred.transpose(1, 0, 2, 3), config)  # (C, T, P, M)
    old = tracks.detection_track
    cost = np.where((old >= 0)[..., None], np.inf, cost)  # assigned detections stay where they are
    has = (old[..., None] == np.arange(m_)).any(2)  # (C, T, M): camera already sees the track
    cost = np.where(has[:, :, None, :], np.inf, cost)
    new = assign_greedy(cost)
    track = np.where(old >= 0, old, new)
    views = (track[..., None] == np.arange(m_)).any(2).sum(0).T  # (M, T)
    gained = (views >= config.min_views) & (views > tracks.views)  # (M, T)
    frame_ok = gained.T[np.arange(t_)[None, :, None], np.maximum(new, 0)]  # (C, T, P)
    track = np.where((old < 0) & (new >= 0) & frame_ok, new, old)
    if (track == old).all():
        return tracks
    groups = track.transpose(1, 0, 2).reshape(t_, c_ * p_)
    mirrored = np.where(track != old, of_group(flipped, groups), tracks.mirrored())  # (C, T, P)
    points = triangulate_groups(rays, groups, flipped=mirrored, num_groups=m_,
                                robust_iters=ROBUST_ITERS).transpose(1, 0, 2, 3)  # (M, T, Ja, 3)
    changed_mt = ((track[..., None] == np.arange(m_)) != (old[..., None] == np.arange(m_))).any(axis=(0, 2)).T
    points = np.where(changed_mt[..., None, None], points, tracks.points_mm)
    views = np.where(changed_mt, (track[..., None] == np.arange(m_)).any(2).sum(0).T, tracks.views)
    with quiet_warnings():
        root = np.where(changed_mt[..., None], np.nanmean(points, axis=2), tracks.root_mm)
    return Tracks(detection_track=track, root_mm=root, points_mm=points, views=views,
                  joint_indices=tracks.joint_indices, camera_names=tracks.camera_names, times_s=tracks.times_s,
                  flipped=mirrored)
