"""Which way round a tracked person is: left and right from the body itself, not from the detector.

Detectors sometimes swap a person's left and right (mostly seen from behind). The association recognises
a detection mirrored relative to the other views (:func:`.refine.reprojection_cost`), but when most views
of a frame are mirrored, the person triangulated from them is the mirror image: its left side is the
body's right. The body says which is right: facing forward is (left - right) x up, and the nose is in
front of the shoulders. Where, over a run of frames in which a track keeps its sides, its nose lies on
median more than ``margin_mm`` behind its shoulders along that direction (:func:`mirrored_frames`), the
run's detections of that track are taken the other way round (their ``flipped`` flags inverted) and its
joints swapped left/right.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from gaitcap.reconstruction.association.rays import quiet_warnings
from gaitcap.reconstruction.association.tracking import Tracks
from gaitcap.reconstruction.skeletons import Skeleton

__all__ = ["face_forward", "mirrored_frames"]

_JOINTS = ("nose", "left_shoulder", "right_shoulder", "left_hip", "right_hip")
MAX_HEAD_MM = 400.0  # farthest a plausible nose lies from the shoulders' midpoint


def mirrored_frames(points_mm: np.ndarray, names: tuple[str, ...], *, up_axis: int = 2,
                    margin_mm: float = 30.0) -> np.ndarray:
    """(T,) bool: which frames of one body ``points_mm`` (T, J, 3) mm with joint ``names`` are its mirror
    image.

    The frames are cut into runs where the body keeps its sides (its left-right direction, shoulders
    plus hips on the floor, turns by less than 90 deg from one frame where it is seen to the next: a
    body turns by a few degrees a frame, a mirror image by 180); a run is mirrored when its nose lies,
    on median over the run, more than ``margin_mm`` behind the shoulders along (left - right) x up. One
    badly placed nose decides nothing. False where the joints are missing or ``names`` lacks them.
    """
    t_ = points_mm.shape[0]
    if any(n not in names for n in _JOINTS):
        return np.zeros(t_, bool)
    ahead, lateral = _nose_ahead(points_mm, names, up_axis)
    seen = np.flatnonzero(np.isfinite(lateral).all(-1))
    out = np.zeros(t_, bool)
    if seen.size == 0:
        return out
    turn = (lateral[seen[1:]] * lateral[seen[:-1]]).sum(-1) < 0  # sides swapped since the last sighting
    run = np.concatenate([[0], np.cumsum(turn)])
    with quiet_warnings():
        for r in range(int(run[-1]) + 1):
            frames = seen[run == r]
            out[frames] = np.nanmedian(ahead[frames]) < -margin_mm
    return out


def _nose_ahead(points_mm: np.ndarray, names: tuple[str, ...], up_axis: int) -> tuple[np.ndarray, np.ndarray]:
    """(T,) mm the nose lies ahead of the shoulders' midpoint along (left - right) x up (NaN where the
    nose is implausible: below the shoulders or farther than ``MAX_HEAD_MM`` from them), and (T, 3) the
    left-right direction (shoulders plus hips, on the floor)."""
    nose, ls, rs, lh, rh = (points_mm[..., names.index(n), :] for n in _JOINTS)
    up = np.zeros(3)
    up[up_axis] = 1.0
    lateral = (ls - rs) + (lh - rh)
    lateral[..., up_axis] = 0.0
    forward = np.cross(lateral, up)
    head = nose - 0.5 * (ls + rs)
    with np.errstate(invalid="ignore", divide="ignore"):
        forward /= np.linalg.norm(forward, axis=-1, keepdims=True)
        ahead = (head * forward).sum(-1)
        plausible = (head[..., up_axis] > 0) & (np.linalg.norm(head, axis=-1) < MAX_HEAD_MM)
    return np.where(plausible, ahead, np.nan), lateral


def face_forward(tracks: Tracks, skeleton: Skeleton, *, up_axis: int = 2, margin_mm: float = 30.0) -> Tracks:
    """``tracks`` with every mirrored track frame (:func:`mirrored_frames`) turned the right way round."""
    if tracks.num_tracks == 0:
        return tracks
    names = tuple(skeleton.joint_names[j] for j in tracks.joint_indices)
    bad = np.stack([mirrored_frames(p, names, up_axis=up_axis, margin_mm=margin_mm)
                    for p in tracks.points_mm])  # (M, T)
    if not bad.any():
        return tracks
    perm = skeleton.flip_permutation
    swap = [names.index(skeleton.joint_names[perm[j]]) if skeleton.joint_names[perm[j]] in names else i
            for i, j in enumerate(tracks.joint_indices)]
    points = np.where(bad[..., None, None], tracks.points_mm[:, :, swap], tracks.points_mm)
    t_ = tracks.detection_track.shape[1]
    own = tracks.detection_track >= 0
    frame = np.broadcast_to(np.arange(t_)[None, :, None], own.shape)
    invert = own & bad[np.maximum(tracks.detection_track, 0), frame]  # (C, T, P)
    return dataclasses.replace(tracks, points_mm=points, flipped=tracks.mirrored() ^ invert)
