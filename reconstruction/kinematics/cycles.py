"""Gait-cycle curves: joint angles cut at heel strikes and resampled to 0-100 % of the cycle."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

CYCLE_POINTS = 101  # 0, 1, ..., 100 % of the gait cycle


@dataclass(frozen=True)
class Cycle:
    """One gait cycle of one foot: heel strike to its next heel strike (s), and the toe-off between (s, or
    NaN when unknown)."""

    side: str
    start_s: float
    end_s: float
    toe_off_s: float = math.nan

    @property
    def toe_off_pct(self) -> float:
        """Toe-off as % of the cycle (NaN if unknown or outside the cycle)."""
        pct = 100.0 * (self.toe_off_s - self.start_s) / (self.end_s - self.start_s)
        return pct if 0.0 < pct < 100.0 else math.nan


@dataclass(frozen=True)
class StepEvent:
    """The gait events of one step: foot, heel strike and the toe-off that ends its stance (s), pass."""

    foot: str
    heel_strike_s: float
    toe_off_s: float
    pass_index: int

    @classmethod
    def of(cls, step) -> StepEvent:
        """From a gait report's step (object) or its JSON form (dict; None = NaN)."""
        get = step.get if isinstance(step, dict) else lambda k: getattr(step, k)
        toe = get("toe_off_s")
        return cls(str(get("foot")), float(get("heel_strike_s")), math.nan if toe is None else float(toe),
                   int(get("pass_index")))


def cycles_from_steps(steps, *, max_cycle_s: float = 2.5) -> list[Cycle]:
    """Cycles between consecutive heel strikes of the same foot within one straight pass.

    ``steps``: the gait report's steps (objects or their JSON dicts with ``foot``, ``heel_strike_s``,
    ``toe_off_s``, ``pass_index``); cycles longer than ``max_cycle_s`` (a missed heel strike) are left out."""
    events = [StepEvent.of(s) for s in steps]
    out = []
    for side in ("left", "right"):
        own = sorted((e for e in events if e.foot == side), key=lambda e: e.heel_strike_s)
        for a, b in zip(own, own[1:], strict=False):
            if a.pass_index != b.pass_index or not 0.0 < b.heel_strike_s - a.heel_strike_s <= max_cycle_s:
                continue
            out.append(Cycle(side, a.heel_strike_s, b.heel_strike_s, a.toe_off_s))
    return out


def normalise(values: np.ndarray, times_s: np.ndarray, cycle: Cycle, *, points: int = CYCLE_POINTS) -> np.ndarray:
    """(points,) ``values`` (T,) linearly resampled from the cycle's start to its end; NaN if the cycle is
    not inside the trial or more than a tenth of its frames are missing (gaps of fewer are interpolated)."""
    t = np.asarray(times_s, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    inside = (t >= cycle.start_s) & (t <= cycle.end_s)
    if cycle.start_s < t[0] or cycle.end_s > t[-1] or inside.sum() < 3:
        return np.full(points, np.nan)
    lo, hi = max(0, int(np.argmax(inside)) - 1), min(t.size, int(np.nonzero(inside)[0][-1]) + 2)
    tt, vv = t[lo:hi], v[lo:hi]
    ok = np.isfinite(vv)
    if ok.sum() < 2 or (~ok[1:-1]).mean() > 0.1:
        return np.full(points, np.nan)
    grid = np.linspace(cycle.start_s, cycle.end_s, points)
    return np.interp(grid, tt[ok], vv[ok])


@dataclass(frozen=True, eq=False)
class CycleCurves:
    """All cycles of one variable on one side: ``curves`` (n, 101) degrees, ``toe_off_pct`` (n,)."""

    curves: np.ndarray
    toe_off_pct: np.ndarray

    @property
    def n(self) -> int:
        return int(self.curves.shape[0])

    @property
    def mean(self) -> np.ndarray:
        return np.mean(self.curves, axis=0) if self.n else np.full(CYCLE_POINTS, np.nan)

    @property
    def sd(self) -> np.ndarray:
        return np.std(self.curves, axis=0, ddof=1) if self.n > 1 else np.full(CYCLE_POINTS, np.nan)


def cycle_curves(values: np.ndarray, times_s: np.ndarray, cycles: list[Cycle], side: str) -> CycleCurves:
    """The complete (no NaN) normalised cycles of ``side``."""
    rows, toe = [], []
    for c in cycles:
        if c.side != side:
            continue
        curve = normalise(values, times_s, c)
        if np.isfinite(curve).all():
            rows.append(curve)
            toe.append(c.toe_off_pct)
    return CycleCurves(np.array(rows).reshape(-1, CYCLE_POINTS), np.array(toe, dtype=np.float64))
