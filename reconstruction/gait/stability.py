"""Do a trial's summary numbers hold? Each parameter's per-side and pooled means, and their symmetry index,
recomputed from the counted steps with each single step left out (leave-one-out).

A finding (a side difference, a value outside a normal range) may rest on a parameter only when each side
has at least :data:`MIN_STEPS_PER_SIDE` counted steps with a value and the finding survives leaving out any
single step (the caller judges that with :meth:`Held.side_difference_holds` and :meth:`Held.beyond`): one
impossible or misplaced step can then never make a finding.

The steps are what ``GaitReport.to_dict()["steps"]`` (the stage's ``gait.json``) holds: dicts with
``foot``, ``steady``, ``excluded`` and the ``STEP_PARAMETERS``. The counted steps are those of the
summary (``parameters.summarise``): the steady ones (all when none is) that are not excluded; the cycle
phases over those of them with every phase measured (all of them when none is); cadence from the step
times (60 / mean, per side from that side's), gait speed from the stride lengths over the stride times.
Pure computation; symmetry index as in ``parameters.GaitSummary``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.gait.parameters import PHASE_PARAMETERS, STEP_PARAMETERS

MIN_STEPS_PER_SIDE = 4
#: a joint-angle key value (one per gait cycle) is held to the same rule: this many cycles on its side,
#: and it must survive leaving out any single cycle (:func:`loo_mean_range`)
MIN_CYCLES_PER_SIDE = MIN_STEPS_PER_SIDE
SIDES = ("left", "right")


def symmetry_index_pct(left: float, right: float) -> float:
    """100 |left - right| / |0.5 (left + right)| (NaN when undefined)."""
    mid = 0.5 * (left + right)
    return float(100.0 * abs(left - right) / abs(mid)) if np.isfinite(mid) and mid else float("nan")


@dataclass(frozen=True)
class Held:
    """One parameter over the counted steps: steps per side with a value, the means with every step
    (``left``, ``right``, ``mean``) and, over leaving out each single step (and none), the range of the
    symmetry index (%) and of the pooled mean (``*_range``: (lowest, highest); NaN when undefined)."""

    n_left: int
    n_right: int
    left: float
    right: float
    mean: float
    si_range: tuple[float, float]
    mean_range: tuple[float, float]

    @property
    def enough(self) -> bool:
        """Each side has at least :data:`MIN_STEPS_PER_SIDE` steps with a value."""
        return min(self.n_left, self.n_right) >= MIN_STEPS_PER_SIDE

    def side_difference_holds(self, threshold_pct: float) -> bool:
        """Enough steps, and the symmetry index stays above ``threshold_pct`` whichever step is left out."""
        return self.enough and bool(self.si_range[0] > threshold_pct)

    def beyond(self, outside: Callable[[float], int]) -> bool:
        """Enough steps, and the pooled mean stays on the same side outside a range whichever step is left
        out: ``outside(value)`` is -1 below the range, +1 above, 0 inside (or unknown)."""
        lo, hi = self.mean_range
        if not (self.enough and np.isfinite(lo) and np.isfinite(hi)):
            return False
        side = outside(lo)
        return side != 0 and outside(hi) == side

    def agrees(self, *, left: float, right: float, mean: float) -> bool:
        """These numbers are the ones shown (``left``, ``right``, ``mean``, NaN where not shown): the summary
        rests on these steps (relative 1e-6, as stored)."""
        return all(_same(a, b) for a, b in ((self.left, left), (self.right, right), (self.mean, mean))
                   if math.isfinite(b))


def loo_mean_range(values: Sequence[float]) -> tuple[float, float]:
    """(lowest, highest) mean of ``values`` over leaving out each single one (and none); (NaN, NaN) with
    fewer than 2 values or any not finite. The means in between lie in that range, so a verdict that is
    the same at both ends (below, or above, a range) holds whichever single value is left out."""
    x = np.asarray(list(values), dtype=np.float64)
    if x.size < 2 or not np.isfinite(x).all():
        return math.nan, math.nan
    means = np.append((x.sum() - x) / (x.size - 1), x.mean())
    return float(means.min()), float(means.max())


def _same(a: float, b: float) -> bool:
    return math.isfinite(a) and abs(a - b) <= 1e-6 * max(abs(a), abs(b)) + 1e-9


def _num(x) -> float:
    return float(x) if isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x) else math.nan


def counted(steps: Sequence[Mapping]) -> list[Mapping]:
    """The steps the summary counts: steady (all when none is) and not excluded."""
    pool = [s for s in steps if s.get("steady", True)] or list(steps)
    return [s for s in pool if not s.get("excluded")]


def _complete(steps: list[Mapping]) -> list[Mapping]:
    return [s for s in steps if all(math.isfinite(_num(s.get(n))) for n in PHASE_PARAMETERS)] or steps


def _loo(values: list[tuple[str, float]], combine: Callable[[float, float, float], tuple[float, float]]):
    """(n_left, n_right, (left, right, pooled means), si range, pooled range) of ``values`` (foot, value)
    over leaving out each one; ``combine(left, right, pooled)`` -> (symmetry index, pooled) shown."""
    feet = np.array([f for f, _ in values])
    x = np.array([v for _, v in values], dtype=np.float64)
    n = {side: int((feet == side).sum()) for side in SIDES}
    sums = {side: float(x[feet == side].sum()) for side in SIDES}

    def means(drop: int | None) -> tuple[float, float, float]:
        out = []
        for side in SIDES:
            k, total = n[side], sums[side]
            if drop is not None and feet[drop] == side:
                k, total = k - 1, total - x[drop]
            out.append(total / k if k else math.nan)
        k, total = len(x) - (drop is not None), float(x.sum()) - (x[drop] if drop is not None else 0.0)
        return out[0], out[1], total / k if k else math.nan

    full = means(None)
    shown = [combine(*means(d)) for d in [None, *range(len(x))]]
    si = np.array([s for s, _ in shown])
    pooled = np.array([p for _, p in shown])
    return n["left"], n["right"], full, _range(si), _range(pooled), combine(*full)


def _range(a: np.ndarray) -> tuple[float, float]:
    return (float(a.min()), float(a.max())) if a.size and np.isfinite(a).all() else (math.nan, math.nan)


def _plain(left: float, right: float, pooled: float) -> tuple[float, float]:
    return symmetry_index_pct(left, right), pooled


def _cadence(left: float, right: float, pooled: float) -> tuple[float, float]:
    per = [60.0 / t if t > 0 else math.nan for t in (left, right)]
    return symmetry_index_pct(*per), 60.0 / pooled if pooled > 0 else math.nan


def leave_one_out(steps: Sequence[Mapping]) -> dict[str, Held]:
    """Per parameter (``STEP_PARAMETERS``, ``cadence_steps_min``, ``gait_speed_m_s``): :class:`Held` over
    the counted steps (see the module docstring)."""
    chosen = counted(steps)
    phases = _complete(chosen)
    out: dict[str, Held] = {}
    for name in (*STEP_PARAMETERS, "cadence_steps_min"):
        source = "step_time_s" if name == "cadence_steps_min" else name
        group = phases if name in PHASE_PARAMETERS else chosen
        values = [(str(s.get("foot")), v) for s in group if math.isfinite(v := _num(s.get(source)))]
        nl, nr, (left, right, pooled), si, mean, (_, shown) = _loo(values, _cadence if name == "cadence_steps_min" else _plain)
        if name == "cadence_steps_min":
            left, right = (60.0 / t if t > 0 else math.nan for t in (left, right))
        out[name] = Held(nl, nr, left, right, shown, si, mean)
    out["gait_speed_m_s"] = _speed(chosen)
    return out


def _speed(steps: list[Mapping]) -> Held:
    """Gait speed (m/s): total stride length over total stride time, with each stride left out."""
    pairs = [(str(s.get("foot")), _num(s.get("stride_length_mm")), _num(s.get("stride_time_s"))) for s in steps]
    pairs = [p for p in pairs if math.isfinite(p[1]) and math.isfinite(p[2])]
    length, time = sum(p[1] for p in pairs), sum(p[2] for p in pairs)
    speeds = [length / time / 1000.0] if time > 0 else []
    speeds += [(length - a) / (time - b) / 1000.0 for _, a, b in pairs if time - b > 0]
    n = {side: sum(p[0] == side for p in pairs) for side in SIDES}
    nan = (math.nan, math.nan)
    return Held(n["left"], n["right"], math.nan, math.nan, speeds[0] if speeds else math.nan, nan,
                _range(np.array(speeds)) if speeds else nan)
