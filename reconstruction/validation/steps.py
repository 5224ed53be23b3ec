"""Spatiotemporal parameters of a reference walk, paired step by step with a trial's.

The reference's steps are computed with gaitcap's own definitions (:func:`gaitcap.reconstruction.gait.
parameters.pass_steps`) from its events (moved onto the trial's clock) and its heel points (moved into the
trial's frame): a contact's heel point is the median of the heel marker over the contact (from heel
strike to toe off), or the walkway footprint's heel. A trial step and a reference step pair when they
are of the same foot and their heel strikes are within ``match_s``. Cadence (60 / mean step time,
steps/min) and speed (total stride length / total stride time, m/s) are computed for both over the
paired steps only, so both describe the same stretch of walking.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.gait.bouts import Pass
from gaitcap.reconstruction.gait.events import Contact
from gaitcap.reconstruction.gait.parameters import pass_steps, progression_direction

#: per-step parameters compared (units in the names)
PARAMETERS = ("step_length_mm", "step_width_mm", "stride_length_mm", "step_time_s", "stride_time_s",
              "stance_pct", "swing_pct", "double_support_pct")
#: per-trial parameters compared
TRIAL_PARAMETERS = ("cadence_steps_min", "speed_m_s")
SIDES = ("left", "right")


@dataclass(frozen=True)
class StepPair:
    """One step of the trial and the reference's step of the same foot; values name -> (trial, reference)."""

    foot: str
    trial_heel_strike_s: float
    reference_heel_strike_s: float
    values: dict[str, tuple[float, float]]


def reference_contacts(heel_strike_s: dict[str, np.ndarray], toe_off_s: dict[str, np.ndarray],
                       heel_at) -> list[Contact]:
    """Contacts (ordered by heel strike) from events (side -> (K,) s, trial clock); ``heel_at(side, t0,
    t1, index)`` gives the (3,) heel point (mm, trial frame) of the contact from t0 to t1 (NaN-free or
    None when the reference has none there)."""
    out = []
    for side in SIDES:
        hs = np.sort(np.asarray(heel_strike_s.get(side, ()), float))
        to = np.sort(np.asarray(toe_off_s.get(side, ()), float))
        for i, t in enumerate(hs):
            end = hs[i + 1] if i + 1 < len(hs) else np.inf
            after = to[(to > t) & (to < end)]
            t_off = float(after[0]) if len(after) else float("nan")
            heel = heel_at(side, float(t), t_off, i)
            ok = heel is not None and np.isfinite(heel).all()
            point = tuple(float(v) for v in heel) if ok else (float("nan"),) * 3
            out.append(Contact(side, float(t), t_off, point, point, 0.0, bool(ok)))
    return sorted(out, key=lambda c: c.heel_strike_s)


def reference_steps(contacts: list[Contact]):
    """gaitcap's steps of the reference's contacts, all in one pass (its direction from the heel points)."""
    valid = [c for c in contacts if c.valid]
    if len(valid) < 2:
        return []
    heels = np.array([c.heel_mm[:2] for c in valid])
    fallback = heels[-1] - heels[0]
    fallback = fallback / (np.linalg.norm(fallback) or 1.0)
    direction = progression_direction([c.foot for c in valid], heels, fallback)
    span = Pass(0, valid[0].heel_strike_s - 1e-6, valid[-1].heel_strike_s + 1e-6, tuple(direction), float("nan"))
    steps, _ = pass_steps(span, contacts, contacts, {})
    return steps


def pair_steps(trial_steps: list[dict], ref_steps, *, match_s: float = 0.25) -> list[StepPair]:
    """Pairs of trial steps (dicts with ``foot``, ``heel_strike_s`` and ``PARAMETERS``; None = not known)
    and reference steps (:class:`~gaitcap.reconstruction.gait.parameters.Step`)."""
    pairs, used = [], set()
    for s in trial_steps:
        t = s.get("heel_strike_s")
        if t is None or not np.isfinite(t):
            continue
        cands = [k for k, r in enumerate(ref_steps) if r.foot == s["foot"] and k not in used
                 and abs(r.heel_strike_s - t) <= match_s]
        if not cands:
            continue
        k = min(cands, key=lambda i: abs(ref_steps[i].heel_strike_s - t))
        used.add(k)
        r = ref_steps[k]
        values = {p: (_num(s.get(p)), float(getattr(r, p))) for p in PARAMETERS}
        pairs.append(StepPair(s["foot"], float(t), float(r.heel_strike_s), values))
    return pairs


def _num(v) -> float:
    return float("nan") if v is None else float(v)


def trial_level(pairs: list[StepPair]) -> dict[str, tuple[float, float]]:
    """Cadence (steps/min) and speed (m/s) of trial and reference over the paired steps (NaN when the
    pairs do not give them)."""
    def both(name):
        a = np.array([[p.values[name][0], p.values[name][1]] for p in pairs]).reshape(-1, 2)
        return a[np.isfinite(a).all(axis=1)]

    step_t = both("step_time_s")
    stride = np.array([[*p.values["stride_length_mm"], *p.values["stride_time_s"]] for p in pairs]).reshape(-1, 4)
    stride = stride[np.isfinite(stride).all(axis=1)]
    nan = float("nan")
    cadence = tuple(60.0 / step_t[:, k].mean() for k in (0, 1)) if len(step_t) else (nan, nan)
    speed = (tuple(stride[:, k].sum() / stride[:, k + 2].sum() / 1000.0 for k in (0, 1))
             if len(stride) else (nan, nan))
    return {"cadence_steps_min": tuple(map(float, cadence)), "speed_m_s": tuple(map(float, speed))}
