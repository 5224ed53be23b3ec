"""Matching a trial's gait events with a reference's (per side and kind), after time alignment.

Reference events are moved onto the trial's clock (``t - lag_s``). Only events that can be judged count:
those at least ``edge_s`` inside both recordings' common span (near either end of a clip an event cannot
be located). Each reference event is matched to the nearest unused trial event of the same side and kind
within ``match_s``; a reference event with none is missed, a trial event matching none is extra. Errors
are trial minus reference (s, and frames of the trial's rate).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SIDES = ("left", "right")
KINDS = ("heel_strike", "toe_off")


@dataclass(frozen=True)
class EventMatchConfig:
    match_s: float = 0.25
    edge_s: float = 0.2


@dataclass(frozen=True)
class EventMatch:
    """One side and kind: matched (trial s, reference s on the trial's clock) pairs, missed reference
    events and extra trial events (s, trial clock)."""

    side: str
    kind: str
    trial_s: tuple[float, ...]
    reference_s: tuple[float, ...]
    missed_s: tuple[float, ...]
    extra_s: tuple[float, ...]

    @property
    def errors_s(self) -> np.ndarray:
        return np.asarray(self.trial_s) - np.asarray(self.reference_s)


def match_events(trial: np.ndarray, reference: np.ndarray, *, lo: float, hi: float, match_s: float
                 ) -> tuple[list[tuple[float, float]], list[float], list[float]]:
    """(matched (trial, reference) pairs, missed reference, extra trial) for events within [lo, hi] (s)."""
    trial = np.sort(np.asarray([t for t in trial if np.isfinite(t) and lo <= t <= hi], float))
    reference = np.sort(np.asarray([t for t in reference if np.isfinite(t) and lo <= t <= hi], float))
    pairs, missed, used = [], [], set()
    for r in reference:
        free = [k for k in range(len(trial)) if k not in used]
        k = min(free, key=lambda i: abs(trial[i] - r)) if free else None
        if k is not None and abs(trial[k] - r) <= match_s:
            used.add(k)
            pairs.append((float(trial[k]), float(r)))
        else:
            missed.append(float(r))
    extra = [float(t) for k, t in enumerate(trial) if k not in used]
    return pairs, missed, extra


def compare_events(trial_events: dict[str, dict[str, np.ndarray]], reference_events: dict[str, dict[str, np.ndarray]],
                   *, lag_s: float, span_s: tuple[float, float],
                   config: EventMatchConfig = EventMatchConfig()) -> list[EventMatch]:
    """``trial_events`` / ``reference_events``: kind -> side -> (K,) s on their own clocks; ``span_s``: the
    common span on the trial's clock. One :class:`EventMatch` per kind and side."""
    lo, hi = span_s[0] + config.edge_s, span_s[1] - config.edge_s
    out = []
    for kind in KINDS:
        for side in SIDES:
            ref = np.asarray(reference_events.get(kind, {}).get(side, ()), float) - lag_s
            pairs, missed, extra = match_events(np.asarray(trial_events.get(kind, {}).get(side, ()), float), ref,
                                                lo=lo, hi=hi, match_s=config.match_s)
            out.append(EventMatch(side, kind, tuple(p[0] for p in pairs), tuple(p[1] for p in pairs),
                                  tuple(missed), tuple(extra)))
    return out


def event_summary(match: EventMatch, fps: float) -> dict:
    """Signed and absolute error statistics of one :class:`EventMatch` (ms and frames at ``fps``)."""
    e = match.errors_s
    nan = float("nan")
    stats = {"n": len(e), "missed": len(match.missed_s), "extra": len(match.extra_s)}
    for unit, scale in (("ms", 1000.0), ("frames", fps)):
        stats[f"signed_median_{unit}"] = float(np.median(e) * scale) if len(e) else nan
        stats[f"signed_mean_{unit}"] = float(np.mean(e) * scale) if len(e) else nan
        stats[f"abs_median_{unit}"] = float(np.median(np.abs(e)) * scale) if len(e) else nan
        stats[f"abs_max_{unit}"] = float(np.max(np.abs(e)) * scale) if len(e) else nan
    return stats
