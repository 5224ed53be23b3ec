"""Temporal linking: per-frame people -> tracks with stable ids.

Each frame's people are matched to the live tracks by an optimal assignment (Hungarian) on the floor
distance between a person's root and the track's predicted root (last root + velocity x elapsed time);
leaving a person unmatched costs ``gate_mm``, so nobody is pushed onto a far track to fill the matching.
The gate grows with the elapsed time, so a track survives missed frames and short occlusions for up to
``max_gap_s``; people who appear start new tracks (unless they sit on a person already matched in that
frame: a second copy of that person), tracks not seen for longer end. Tracks (almost) never seen together
and close where they alternate or meet are stitched into one. Very short tracks
(flicker) are dropped at the end. The loop is over frames only, on arrays of a few people.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.association.crossview import FramePeople
from scipy.optimize import linear_sum_assignment

_FAR = 1e12


@dataclass(frozen=True)
class TrackingConfig:
    """Settings of the temporal linking.

    Attributes:
        gate_mm: a person may join a track whose predicted root is within this distance ...
        max_speed_mm_s: ... plus this speed times the time since the track was last seen.
        max_gap_s: a track not seen for longer ends.
        velocity_smoothing: weight of the newest velocity estimate (exponential smoothing, 0..1].
        min_track_s: tracks shorter than this (first to last frame) are discarded.
        duplicate_mm: an unmatched person this close to a matched one in the same frame is taken for a
            second copy of that person and starts no track (its detections stay unassigned).
        min_views_to_start: a person seen by fewer cameras may continue a track but not start one.
        stitch_mm, stitch_window_s, stitch_overlap: two tracks seen in the same frame more than
            ``duplicate_mm`` apart at most in a fraction ``stitch_overlap`` of the shorter one's frames,
            whose sightings lie within
            ``stitch_mm`` of each other (median, sightings at most ``stitch_window_s`` apart), are one
            person and are merged (a noisy, rarely seen person whose position once jumped its gate).
        up_axis: vertical world axis, ignored when matching (a root's height shifts with the joints
            seen); None compares in 3D.
    """

    gate_mm: float = 350.0
    max_speed_mm_s: float = 2500.0
    max_gap_s: float = 1.5
    velocity_smoothing: float = 0.3
    min_track_s: float = 0.2
    duplicate_mm: float = 300.0
    min_views_to_start: int = 3
    stitch_mm: float = 500.0
    stitch_window_s: float = 0.3
    stitch_overlap: float = 0.05
    up_axis: int | None = 2

    def __post_init__(self) -> None:
        for name in ("gate_mm", "max_speed_mm_s", "max_gap_s", "velocity_smoothing"):
            if not getattr(self, name) > 0:
                raise ValueError(f"TrackingConfig.{name} must be > 0, got {getattr(self, name)}")
        if self.up_axis not in (None, 0, 1, 2):
            raise ValueError(f"TrackingConfig.up_axis must be None, 0, 1 or 2, got {self.up_axis}")
        if self.velocity_smoothing > 1 or self.min_track_s < 0:
            raise ValueError("TrackingConfig: velocity_smoothing must be <= 1 and min_track_s >= 0")


@dataclass(frozen=True, eq=False)
class Tracks:
    """People linked over time.

    Attributes:
        detection_track: (C, T, P) int: track id of detection (c, t, p), -1 for none.
        root_mm: (M, T, 3) each track's root (mean of its association joints), NaN where not seen.
        points_mm: (M, T, Ja, 3) each track's association joints, NaN where not seen.
        views: (M, T) number of cameras that see the track in each frame.
        joint_indices: (Ja,) skeleton indices of the association joints.
        camera_names: (C,) camera order of ``detection_track``.
        times_s: (T,) frame times.
        flipped: (C, T, P) bool: detection (c, t, p) shows its track mirrored left/right (the detector
            swapped the sides; :func:`~gaitcap.reconstruction.association.selection.patient_detections`
            swaps them back); None: not known (taken as False).
    Track ids are 0..M-1 in order of first appearance.
    """

    detection_track: np.ndarray
    root_mm: np.ndarray
    points_mm: np.ndarray
    views: np.ndarray
    joint_indices: tuple[int, ...]
    camera_names: tuple[str, ...]
    times_s: np.ndarray
    flipped: np.ndarray | None = None

    def mirrored(self) -> np.ndarray:
        """(C, T, P) bool: :attr:`flipped`, all False when not known."""
        if self.flipped is None:
            return np.zeros(self.detection_track.shape, bool)
        return self.flipped & (self.detection_track >= 0)

    @property
    def num_tracks(self) -> int:
        return self.root_mm.shape[0]

    @property
    def ids(self) -> tuple[int, ...]:
        return tuple(range(self.num_tracks))

    def check_id(self, track_id: int) -> int:
        """``track_id`` as int; ValueError naming the valid ids when it does not exist."""
        if not isinstance(track_id, int | np.integer) or not 0 <= int(track_id) < self.num_tracks:
            raise ValueError(f"track id {track_id!r} does not exist (tracks: {list(self.ids)})")
        return int(track_id)

    def seen(self) -> np.ndarray:
        """(M, T) bool: frames in which each track is seen."""
        return self.views > 0

    def summaries(self) -> tuple[TrackSummary, ...]:
        """One line per track, e.g. for a page listing the people to choose from."""
        out = []
        for m in self.ids:
            seen = np.flatnonzero(self.views[m] > 0)
            steps = np.diff(self.root_mm[m, seen], axis=0)
            out.append(TrackSummary(
                track_id=m, first_s=float(self.times_s[seen[0]]), last_s=float(self.times_s[seen[-1]]),
                frames=int(seen.size), mean_views=float(self.views[m, seen].mean()),
                path_mm=float(np.nansum(np.linalg.norm(steps, axis=-1))),
                mean_position_mm=tuple(float(v) for v in np.nanmean(self.root_mm[m, seen], axis=0)),
            ))
        return tuple(out)


@dataclass(frozen=True)
class TrackSummary:
    """A track in brief: id, first and last time seen (s), frames seen, mean number of cameras, path
    length of its root (mm) and mean root position (x, y, z mm)."""

    track_id: int
    first_s: float
    last_s: float
    frames: int
    mean_views: float
    path_mm: float
    mean_position_mm: tuple[float, float, float]


def link_tracks(people: FramePeople, times_s: np.ndarray, camera_names, config: TrackingConfig) -> Tracks:
    """Link per-frame people into tracks (see the module docstring)."""
    times_s = np.asarray(times_s, dtype=np.float64)
    t_, k_ = people.views.shape
    track_of = np.full((t_, k_), -1)  # frame person -> track
    pos = people.root_mm if config.up_axis is None else np.delete(people.root_mm, config.up_axis, -1)
    state = _State()
    for t in range(t_):
        present = np.flatnonzero(people.views[t] > 0)
        if present.size == 0:
            continue
        now, xy = times_s[t], pos[t, present]
        matched = _match(xy, state, now, config)
        taken = [xy[row] for row in matched]
        for row in np.argsort(-people.views[t, present], kind="stable"):  # best-seen first
            i = matched.get(row)
            if i is None:
                if people.views[t, present[row]] < config.min_views_to_start:
                    continue  # too few cameras to tell a person from a chance match: no new track
                if taken and np.min(np.linalg.norm(np.array(taken) - xy[row], axis=-1)) < config.duplicate_mm:
                    continue  # a second copy of a person already tracked in this frame: no new track
                i = state.start(xy[row], now)
                taken.append(xy[row])
            else:
                state.update(i, xy[row], now, config.velocity_smoothing)
            track_of[t, present[row]] = i
    track_of = _stitch(track_of, pos, times_s, config)
    return _build(people, track_of, len(state.last), times_s, tuple(camera_names), config)


def _stitch(track_of: np.ndarray, pos: np.ndarray, times_s: np.ndarray, config: TrackingConfig) -> np.ndarray:
    """Merge tracks that are one person: (almost) never seen in the same frame, and close where they
    alternate or meet (a noisy, rarely seen person whose position jumped out of its gate once).

    Args: track_of (T, K) track of each frame person (-1 none); pos (T, K, D) their positions mm.
    """
    m_ = int(track_of.max()) + 1
    if m_ < 2:
        return track_of
    series = np.full((m_, *pos.shape[::2]), np.nan)  # (M, T, D)
    tt, kk = np.nonzero(track_of >= 0)
    series[track_of[tt, kk], tt] = pos[tt, kk]
    alias = np.arange(m_)
    for j in range(1, m_):
        for i in range(j):
            if alias[i] == i and _one_person(series[i], series[j], times_s, config):
                series[i] = np.where(np.isfinite(series[i]), series[i], series[j])
                alias[alias == j] = i
                break
    return np.where(track_of >= 0, alias[np.maximum(track_of, 0)], -1)


def _one_person(a: np.ndarray, b: np.ndarray, times_s: np.ndarray, config: TrackingConfig) -> bool:
    """Tracks a, b (T, D) are one person: rarely seen apart in the same frame (more than
    ``duplicate_mm``, in at most ``stitch_overlap`` of the shorter one's frames; nearer is a duplicate)
    and, on median, b's sightings lie within ``stitch_mm`` of a's nearest
    sighting (at most ``stitch_window_s`` away; same-frame sightings compare directly)."""
    seen_a, seen_b = np.isfinite(a[:, 0]), np.isfinite(b[:, 0])
    apart = np.linalg.norm(a - b, axis=-1) > config.duplicate_mm  # NaN -> False: together, apart
    if not seen_a.any() or not seen_b.any() or apart.sum() > config.stitch_overlap * min(
            seen_a.sum(), seen_b.sum()):
        return False
    fa, fb = np.flatnonzero(seen_a), np.flatnonzero(seen_b)
    at = np.searchsorted(fa, fb)
    before, after = fa[np.clip(at - 1, 0, len(fa) - 1)], fa[np.clip(at, 0, len(fa) - 1)]
    near = np.where(np.abs(before - fb) <= np.abs(after - fb), before, after)
    close = np.abs(times_s[near] - times_s[fb]) <= config.stitch_window_s
    if not close.any():
        return False
    dist = np.linalg.norm(a[near[close]] - b[fb[close]], axis=-1)
    return bool(np.median(dist) < config.stitch_mm)


class _State:
    """Last position, time and smoothed velocity of every track (floor or 3D coordinates, mm)."""

    def __init__(self) -> None:
        self.last: list[np.ndarray] = []
        self.time: list[float] = []
        self.velocity: list[np.ndarray] = []

    def start(self, position: np.ndarray, now: float) -> int:
        self.last.append(position)
        self.time.append(now)
        self.velocity.append(np.zeros_like(position))
        return len(self.last) - 1

    def update(self, i: int, position: np.ndarray, now: float, smoothing: float) -> None:
        v_new = (position - self.last[i]) / (now - self.time[i])
        self.velocity[i] = (1 - smoothing) * self.velocity[i] + smoothing * v_new
        self.last[i], self.time[i] = position, now


def _match(xy: np.ndarray, state: _State, now: float, config: TrackingConfig) -> dict[int, int]:
    """Hungarian assignment of this frame's people (rows) to live tracks -> {row: track index}."""
    live = [i for i in range(len(state.last)) if now - state.time[i] <= config.max_gap_s]
    if not live:
        return {}
    dt = np.array([now - state.time[i] for i in live])
    pred = np.stack([state.last[i] for i in live]) + np.stack([state.velocity[i] for i in live]) * dt[:, None]
    dist = np.linalg.norm(xy[:, None, :] - pred[None], axis=-1)  # (rows, live)
    gate = config.gate_mm + config.max_speed_mm_s * dt
    cost = np.where(dist <= gate[None], dist, _FAR)
    # one "stays unmatched" column per row costing gate_mm, so no one is forced onto a far track
    n_rows = len(xy)
    leave = np.full((n_rows, n_rows), _FAR)
    np.fill_diagonal(leave, config.gate_mm)
    rows, cols = linear_sum_assignment(np.hstack([cost, leave]))
    return {int(r): live[c] for r, c in zip(rows, cols, strict=True) if c < len(live) and cost[r, c] < _FAR}


def _build(people: FramePeople, track_of, m_, times_s, camera_names, config) -> Tracks:
    t_ = len(times_s)
    frames = [np.flatnonzero((track_of == i).any(1)) for i in range(m_)]
    keep = [i for i in range(m_) if frames[i].size and times_s[frames[i][-1]] - times_s[frames[i][0]]
            >= config.min_track_s]
    remap = np.full(m_ + 1, -1)
    remap[keep] = np.arange(len(keep))
    track_of = remap[track_of]  # -1 stays -1 via the last entry
    ja = people.points_mm.shape[2]
    m_ = len(keep)
    root = np.full((m_, t_, 3), np.nan)
    points = np.full((m_, t_, ja, 3), np.nan)
    views = np.zeros((m_, t_), int)
    tt, kk = np.nonzero(track_of >= 0)
    ids = track_of[tt, kk]
    root[ids, tt] = people.root_mm[tt, kk]
    points[ids, tt] = people.points_mm[tt, kk]
    views[ids, tt] = people.views[tt, kk]
    labels = people.labels
    frame = np.broadcast_to(np.arange(t_)[None, :, None], labels.shape)
    det_track = np.where(labels >= 0, track_of[frame, np.maximum(labels, 0)], -1)
    flipped = None if people.flipped is None else people.flipped & (det_track >= 0)
    return Tracks(detection_track=det_track, root_mm=root, points_mm=points, views=views,
                  joint_indices=people.joint_indices, camera_names=camera_names, times_s=times_s,
                  flipped=flipped)
