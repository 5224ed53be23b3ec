"""Frames of unsynchronised cameras paired by time, and board views that moved between the cameras'
exposures.

Webcams and USB cameras deliver frames at slightly different times. Frames are paired when their times
lie within a tolerance (default: half the median frame interval). A board seen by two cameras a few ms
apart while it moves is in two different places: a view whose corner speed (px/s, from the same
camera's neighbouring views) times its time offset from the pair's median time exceeds ``max_shift_px``
is taken out of the pair and kept as a frame of its own (its camera's intrinsics still use it), so that
extrinsics come from still boards.

A webcam also takes time to expose one frame: its rolling shutter reads the rows out one after another
over several ms, so a moving board comes out skewed and smeared even in a perfectly synchronised pair.
With ``readout_ms`` (0 by default: rendered boards and global-shutter cameras need none) a view whose
board moved more than ``max_shift_px`` within the readout is left out altogether (skewed, it would
mislead the intrinsics too); a camera never loses more than ``max_moving_fraction`` of its views this
way (the fastest go first), so that a mostly moving clip still ties every camera in.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

MISSING = -1
MOTION_WINDOW_S = 0.5  # neighbouring views further apart than this say nothing about the speed


@dataclass(frozen=True)
class PairingConfig:
    """tolerance_ms: frames closer than this pair (None: half the median frame interval);
    max_shift_px: largest board shift (speed x time offset, or speed x readout) accepted in a view, px;
    readout_ms: time one frame takes to be read out (rolling shutter), ms;
    max_moving_fraction: at most this fraction of a camera's views is left out as smeared."""

    tolerance_ms: float | None = field(default=None, metadata={"option": "--sync-tolerance-ms"})
    max_shift_px: float = 1.0
    readout_ms: float = field(default=0.0, metadata={"option": "--readout-ms"})
    max_moving_fraction: float = 0.5

    def __post_init__(self) -> None:
        if self.tolerance_ms is not None and self.tolerance_ms <= 0:
            raise ValueError(f"pairing: tolerance_ms must be > 0, got {self.tolerance_ms}")
        if self.max_shift_px <= 0:
            raise ValueError(f"pairing: max_shift_px must be > 0, got {self.max_shift_px}")
        if self.readout_ms < 0:
            raise ValueError(f"pairing: readout_ms must be >= 0, got {self.readout_ms}")
        if not 0 <= self.max_moving_fraction <= 1:
            raise ValueError(f"pairing: max_moving_fraction must lie in [0, 1], got {self.max_moving_fraction}")

    def asked(self) -> tuple[str, ...]:
        """The fields set away from their defaults, each as ``name value`` with the command-line option that
        sets it (e.g. ``readout_ms 20 (--readout-ms)``): all of them need frame times, so frames paired by
        order refuse them rather than ignore them."""
        out = []
        for f in fields(self):
            value = getattr(self, f.name)
            if value != f.default:
                option = f" ({f.metadata['option']})" if "option" in f.metadata else ""
                out.append(f"{f.name} {value:g}{option}")
        return tuple(out)


def default_tolerance_ns(times_ns: list[np.ndarray]) -> int:
    """Half the median interval between consecutive frames over all cameras, ns (at least 1)."""
    gaps = [np.diff(np.sort(t)) for t in times_ns if len(t) > 1]
    gaps = np.concatenate(gaps) if gaps else np.zeros(0)
    gaps = gaps[gaps > 0]
    return max(1, int(np.median(gaps) // 2)) if gaps.size else 1


def pair_by_time(times_ns: list[np.ndarray], tolerance_ns: int) -> np.ndarray:
    """Frame sets (S, C) of frame indices (-1 where a camera has none) from each camera's frame times.

    Greedy in time order: a set starts at its earliest frame and takes, from each camera, its first
    frame no later than ``tolerance_ns`` after that start. Sets come out in time order.
    """
    cam = np.concatenate([np.full(len(t), c) for c, t in enumerate(times_ns)]).astype(int)
    idx = np.concatenate([np.arange(len(t)) for t in times_ns]).astype(int)
    t_all = np.concatenate([np.asarray(t, dtype=np.int64) for t in times_ns])
    order = np.argsort(t_all, kind="stable")
    sets: list[np.ndarray] = []
    start = None
    for k in order:
        if start is None or t_all[k] - start > tolerance_ns or sets[-1][cam[k]] != MISSING:
            sets.append(np.full(len(times_ns), MISSING))
            start = t_all[k]
        sets[-1][cam[k]] = idx[k]
    return np.stack(sets) if sets else np.zeros((0, len(times_ns)), dtype=int)


def board_speed_px_s(corners_px: np.ndarray, times_s: np.ndarray) -> np.ndarray:
    """Corner speed (px/s) of each view of one camera: median corner displacement to its nearest view
    (in time, within ``MOTION_WINDOW_S``) over the time between them; NaN without such a neighbour.

    corners_px: (F, N, 2), NaN where unseen; times_s: (F,) this camera's frame times, s.
    """
    seen = np.any(np.isfinite(corners_px[..., 0]), axis=1)
    speed = np.full(len(times_s), np.nan)
    views = np.flatnonzero(seen)
    for k, f in enumerate(views):
        best = np.nan
        for g in (views[k - 1] if k > 0 else None, views[k + 1] if k + 1 < len(views) else None):
            if g is None:
                continue
            dt = abs(times_s[g] - times_s[f])
            if 0 < dt <= MOTION_WINDOW_S:
                d = np.linalg.norm(corners_px[g] - corners_px[f], axis=-1)
                d = d[np.isfinite(d)]
                if d.size:
                    v = float(np.median(d)) / dt
                    best = v if np.isnan(best) else min(best, v)
        speed[f] = best
    return speed


def _speeds(corners_px: np.ndarray, times_s: np.ndarray) -> np.ndarray:
    """(C, F) board speed px/s of every camera's views (NaN where unknown); times_s (C, F), NaN = no frame."""
    speed = np.full(corners_px.shape[:2], np.nan)
    for c in range(corners_px.shape[0]):
        ok = np.isfinite(times_s[c])
        speed[c, ok] = board_speed_px_s(corners_px[c, ok], times_s[c, ok])
    return speed


def moving_views(corners_px: np.ndarray, times_s: np.ndarray, set_times_s: np.ndarray,
                 max_shift_px: float) -> np.ndarray:
    """(C, F) views whose board shift over their time offset from the set's time exceeds ``max_shift_px``.

    corners_px: (C, F, N, 2); times_s: (C, F) each camera's frame time (NaN where it has no frame);
    set_times_s: (F,) the set's time (median over its cameras).
    """
    shift = _speeds(corners_px, times_s) * np.abs(times_s - set_times_s)
    return np.isfinite(shift) & (shift > max_shift_px)


def smeared_views(corners_px: np.ndarray, times_s: np.ndarray, max_shift_px: float, *, readout_s: float,
                  max_fraction: float = 0.5) -> np.ndarray:
    """(C, F) views whose board moved more than ``max_shift_px`` while the frame was read out
    (``readout_s``): skewed by a rolling shutter, they are wrong for intrinsics and extrinsics alike. Per
    camera at most ``max_fraction`` of its views, the fastest first.

    corners_px: (C, F, N, 2); times_s: (C, F) each camera's frame time (NaN where it has no frame).
    """
    out = np.zeros(corners_px.shape[:2], dtype=bool)
    if readout_s <= 0:
        return out
    shift = _speeds(corners_px, times_s) * readout_s
    for c in range(corners_px.shape[0]):
        over = np.flatnonzero(np.isfinite(shift[c]) & (shift[c] > max_shift_px))
        views = int(np.any(np.isfinite(corners_px[c, ..., 0]), axis=-1).sum())
        out[c, over[np.argsort(-shift[c, over])][: int(np.floor(max_fraction * views))]] = True
    return out


def separate_moving(corners_px: np.ndarray, cam_t: np.ndarray, times_s: np.ndarray, pairing: PairingConfig,
                    *, timed: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Frame sets with the views of a moving board dealt with: those smeared during the readout left out,
    those that moved between the cameras' exposures split off (:func:`split_moving`). Nothing when the
    frames have no times (``timed`` False: ``cam_t`` holds frame indices).

    corners_px: (C, F, N, 2), changed in place; cam_t: (C, F) each camera's frame time, s (NaN: no frame);
    times_s: (F,) the sets' times -> corners (C, F', N, 2), times (F',), and per camera (C,) the views
    split off (moving) and those left out (smeared).
    """
    if not timed:
        none = np.zeros(corners_px.shape[0], dtype=int)
        return corners_px, times_s, none, none
    smeared = smeared_views(corners_px, cam_t, pairing.max_shift_px, readout_s=pairing.readout_ms / 1000,
                            max_fraction=pairing.max_moving_fraction)
    corners_px[smeared] = np.nan  # skewed by the rolling shutter: no use for intrinsics or extrinsics
    set_t = np.nanmedian(cam_t, axis=0) if cam_t.size else np.zeros(0)  # every set holds a frame
    moving = moving_views(corners_px, cam_t, set_t, pairing.max_shift_px)
    corners_px, times_s = split_moving(corners_px, times_s, moving)
    return corners_px, times_s, moving.sum(1), smeared.sum(1)


def split_moving(corners_px: np.ndarray, times_s: np.ndarray, moving: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Moving views taken out of their frame sets, each kept as a frame of its own right after it: it
    still serves its camera's intrinsics but ties no cameras together.

    corners_px: (C, F, N, 2); times_s: (F,); moving: (C, F) -> corners (C, F', N, 2), times (F',).
    """
    cols, times = [], []
    for f in range(corners_px.shape[1]):
        kept = corners_px[:, f].copy()
        kept[moving[:, f]] = np.nan
        cols.append(kept)
        times.append(times_s[f])
        for c in np.flatnonzero(moving[:, f]):
            alone = np.full_like(kept, np.nan)
            alone[c] = corners_px[c, f]
            cols.append(alone)
            times.append(times_s[f])
    if not cols:
        return corners_px, times_s
    return np.stack(cols, axis=1), np.asarray(times)
