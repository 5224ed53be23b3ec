"""The foot and body-centre tracks gait analysis works on, as continuous functions of time.

`FootTracks.from_points` picks heel, toe and body-centre joints by name from any skeleton, fills short
NaN gaps (longer ones are marked invalid, never analysed) and wraps the result in a continuous sampler:
either the caller's own ``sample(times_s) -> (N, J, 3)`` (e.g. an implicit trajectory) or a cubic spline
through the frames. Events are then located on that continuous function at sub-frame precision.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.gait.config import GaitConfig
from scipy.interpolate import CubicSpline
from scipy.signal import savgol_filter

SIDES = ("left", "right")
# Row order of the tracked points: left heel, left toe, right heel, right toe, body centre.
HEEL = {"left": 0, "right": 2}
TOE = {"left": 1, "right": 3}
CENTER = 4
_TOE_NAMES = ("big_toe", "foot_index")
_CENTER_NAMES = (("left_hip", "right_hip"), ("pelvis",), ("hip",), ("mid_hip",))

Sampler = Callable[[np.ndarray], np.ndarray]


def _find(names: Sequence[str], wanted: str) -> int | None:
    return names.index(wanted) if wanted in names else None


def foot_joint_indices(joint_names: Sequence[str]) -> tuple[list[int], list[int]]:
    """Indices of [left heel, left toe, right heel, right toe] and of the body-centre joints.

    Raises ValueError naming the missing joint when the skeleton has no heels or toes.
    """
    names = [str(n) for n in joint_names]
    feet = []
    for side in SIDES:
        heel = _find(names, f"{side}_heel")
        if heel is None:
            raise ValueError(f"joint_names: no '{side}_heel' joint (gait analysis needs heels and toes)")
        toe = next((_find(names, f"{side}_{t}") for t in _TOE_NAMES if f"{side}_{t}" in names), None)
        if toe is None:
            raise ValueError(f"joint_names: no '{side}_big_toe' joint (gait analysis needs heels and toes)")
        feet += [heel, toe]
    center = next(([names.index(n) for n in group] for group in _CENTER_NAMES
                   if all(n in names for n in group)), feet)
    return feet, center


def _fill_gaps(values: np.ndarray, times_s: np.ndarray, max_gap_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Interpolate NaN runs of each point of (T, K, 3); return filled values and a (T, K) trusted mask."""
    filled = values.copy()
    valid = np.isfinite(values).all(axis=2)
    for k in range(values.shape[1]):
        bad = ~valid[:, k]
        if not bad.any():
            continue
        good = np.flatnonzero(~bad)
        for c in range(3):
            filled[:, k, c] = np.interp(times_s, times_s[good], values[good, k, c])
        # Short interior gaps are trusted once interpolated; long gaps and gaps at the ends are not.
        edges = np.flatnonzero(np.diff(np.r_[0, bad.astype(int), 0]))
        for start, stop in zip(edges[::2], edges[1::2], strict=True):
            interior = start > 0 and stop < len(times_s)
            span = times_s[min(stop, len(times_s) - 1)] - times_s[max(start - 1, 0)]
            if interior and span <= max_gap_s:
                valid[start:stop, k] = True
    return filled, valid


@dataclass(frozen=True, eq=False)
class FootTracks:
    """Heel, toe and body-centre tracks of one trial.

    Attributes:
        times_s: (T,) frame times (s, strictly increasing).
        frames_mm: (T, 5, 3) left heel, left toe, right heel, right toe, body centre (mm, z up),
            with short NaN gaps filled.
        valid: (T, 5) False inside long NaN gaps of a point (nothing is measured there).
        sampler: continuous ``sample(times_s (N,)) -> (N, 5, 3)`` mm of the same points.
        gaps_s: per point, (start s, end s) of its untrusted gaps.
        continuous: True when the sampler is the caller's continuous trajectory (not a spline).
    """

    times_s: np.ndarray
    frames_mm: np.ndarray
    valid: np.ndarray
    sampler: Sampler
    gaps_s: tuple[tuple[tuple[float, float], ...], ...]
    continuous: bool = False

    @classmethod
    def from_points(
        cls,
        points_mm: np.ndarray,
        times_s: np.ndarray,
        joint_names: Sequence[str],
        *,
        sample: Callable[[np.ndarray], np.ndarray] | None = None,
        config: GaitConfig = GaitConfig(),
    ) -> FootTracks:
        """Validate a (T, J, 3) trajectory and build the tracks (see the module docstring)."""
        points, times = _validated(points_mm, times_s, joint_names, config)
        feet, center = foot_joint_indices(joint_names)
        frames = np.concatenate([points[:, feet], points[:, center].mean(axis=1, keepdims=True)], axis=1)
        finite = np.isfinite(frames).all(axis=(1, 2))
        if finite.sum() < max(4, 0.25 * len(times)):
            raise ValueError(f"heel/toe joints are NaN in {np.sum(~finite)} of {len(times)} frames: "
                             "not enough data for gait analysis")
        filled, valid = _fill_gaps(frames, times, config.max_fill_gap_s)
        gaps = tuple(_runs(~valid[:, k], times) for k in range(valid.shape[1]))
        if sample is not None:
            sampler = _caller_sampler(sample, feet, center, times)
            sampled = sampler(times)
            return cls(times, np.where(np.isfinite(sampled), sampled, filled), valid, sampler, gaps, continuous=True)
        window = config.smoothing_window_s
        if window is None:
            raw = cls(times, filled, valid, _spline_sampler(times, filled), gaps)
            noisy = raw.rest_noise_mm_s() > config.auto_smoothing_noise_mm_s
            window = config.auto_smoothing_window_s if noisy else 0.0
        frames_out = _smooth(filled, times, window)
        return cls(times, frames_out, valid, _spline_sampler(times, frames_out), gaps)

    def frame_spline(self) -> FootTracks:
        """The same tracks with a cubic spline through ``frames_mm`` as sampler (self if already one)."""
        if not self.continuous:
            return self
        return FootTracks(self.times_s, self.frames_mm, self.valid, _spline_sampler(self.times_s, self.frames_mm),
                          self.gaps_s)

    def rest_noise_mm_s(self, frames: np.ndarray | None = None) -> float:
        """Noise floor of the feet's speed at rest (mm/s): the 25th percentile over trusted frames of the
        slower of heel and toe, the median over both feet (feet rest over half of a walking trial).
        ``frames``: (T,) bool, the frames to take it over (default all; the walking ones, ``Bouts.walking``,
        for the feet's stances: feet standing still are stiller than feet in stance while walking)."""
        speed = self.speed_mm_s(self.times_s)
        out = []
        for side in SIDES:
            m = np.minimum(speed[:, HEEL[side]], speed[:, TOE[side]])
            ok = self.valid[:, HEEL[side]] & self.valid[:, TOE[side]]
            ok = ok & frames if frames is not None and (ok & frames).sum() >= 4 else ok
            out.append(np.nanpercentile(m[ok], 25) if np.isfinite(m[ok]).any() else np.nan)
        return float(np.nanmedian(out))

    def speed_mm_s(self, times_s: np.ndarray, h_s: float = 1e-3) -> np.ndarray:
        """(N, 5) speed of each tracked point (mm/s) by a central difference on the sampler."""
        t = np.asarray(times_s, dtype=np.float64)
        both = self.sampler(np.concatenate([t + h_s, t - h_s]))
        return np.linalg.norm(both[: len(t)] - both[len(t):], axis=-1) / (2 * h_s)

    def is_valid(self, start_s: float, end_s: float, rows: Sequence[int] = range(5)) -> bool:
        """True when [start_s, end_s] overlaps no untrusted gap of the given point rows."""
        return all(end_s < a or start_s > b for k in rows for a, b in self.gaps_s[k])

    @property
    def all_gaps_s(self) -> list[tuple[float, float]]:
        """Sorted untrusted gaps of any point (s)."""
        return sorted({g for gaps in self.gaps_s for g in gaps})


def _validated(points_mm, times_s, joint_names, config: GaitConfig) -> tuple[np.ndarray, np.ndarray]:
    """(T, J, 3) points and (T,) times as float arrays; ValueError naming what is wrong."""
    points = np.asarray(points_mm, dtype=np.float64)
    times = np.asarray(times_s, dtype=np.float64)
    if points.ndim != 3 or points.shape[-1] != 3:
        raise ValueError(f"points_mm: expected shape (T, J, 3), got {points.shape}")
    if times.shape != (points.shape[0],):
        raise ValueError(f"times_s: expected shape ({points.shape[0]},), got {times.shape}")
    if len(joint_names) != points.shape[1]:
        raise ValueError(f"joint_names: {len(joint_names)} names for {points.shape[1]} joints")
    if not np.isfinite(times).all() or (np.diff(times) <= 0).any():
        raise ValueError("times_s: must be finite and strictly increasing")
    if len(times) < 4 or times[-1] - times[0] < config.min_trial_s:
        duration = times[-1] - times[0] if len(times) else 0.0
        raise ValueError(f"trial too short: {duration:.2f} s (need at least {config.min_trial_s} s)")
    return points, times


def _caller_sampler(sample: Callable[[np.ndarray], np.ndarray], feet: list[int], center: list[int],
                    times_s: np.ndarray) -> Sampler:
    """The caller's (N,) -> (N, J, 3) function reduced to the 5 tracked points, clipped to the trial."""
    index = np.asarray(feet + [center[0]])
    lo, hi = float(times_s[0]), float(times_s[-1])

    def sampler(t: np.ndarray) -> np.ndarray:
        t = np.clip(np.asarray(t, dtype=np.float64), lo, hi)  # the caller's may refuse outside
        full = np.asarray(sample(t), dtype=np.float64)
        out = full[:, index]
        out[:, CENTER] = full[:, center].mean(axis=1)
        return out

    return sampler


def _spline_sampler(times_s: np.ndarray, frames: np.ndarray) -> Sampler:
    spline = CubicSpline(times_s, frames, axis=0, extrapolate=True)

    def sampler(t: np.ndarray) -> np.ndarray:
        return spline(np.asarray(t, dtype=np.float64))

    return sampler


def _smooth(frames: np.ndarray, times_s: np.ndarray, window_s: float) -> np.ndarray:
    if window_s <= 0:
        return frames
    dt = float(np.median(np.diff(times_s)))
    window = int(round(window_s / dt)) | 1
    if window < 5 or window > len(times_s):
        return frames
    return savgol_filter(frames, window, 3, axis=0, mode="interp")


def _runs(mask: np.ndarray, times_s: np.ndarray) -> tuple[tuple[float, float], ...]:
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(int), 0]))
    return tuple((float(times_s[a]), float(times_s[b - 1])) for a, b in zip(edges[::2], edges[1::2], strict=True))
