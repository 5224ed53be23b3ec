"""A gait report's events and steps against a synthetic walk's ground truth (``truth.GaitTruth``).

What the analysis must never do, counted (``EventCheck``): miss a contact that the truth has inside a
pass's steady part (a contact of that foot within ``tolerance_s`` of the true heel strike), form a step on
a heel strike the truth does not have (made up), rest a step on a toe off outside the stance its heel strike
began (between the true heel strike and the same foot's next one), or form a step of negative length (kept
or dropped). Also counted: the steps check's items (excluded steps, missed contacts, dropped steps).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gaitcap.simulator.truth import GaitTruth

TOLERANCE_S = 0.25  # a found heel strike farther than this from every true one of its foot is not that one


@dataclass(frozen=True)
class EventCheck:
    """Counts over one report (see the module docstring); ``problems``: each one in words."""

    steps: int
    counted: int
    excluded: int
    missed_contacts: int
    dropped_steps: int
    missed_in_pass: int
    made_up: int
    toe_off_outside_stance: int
    negative_steps: int
    problems: tuple[str, ...]

    @property
    def steps_check_items(self) -> int:
        """What the trial's steps check names: excluded steps, missed contacts and dropped steps."""
        return self.excluded + self.missed_contacts + self.dropped_steps

    @property
    def truth_errors(self) -> int:
        """Events that the truth shows wrong: missed in a pass, made up, toe offs outside their stance and
        negative steps."""
        return self.missed_in_pass + self.made_up + self.toe_off_outside_stance + self.negative_steps


def _nearest(times: np.ndarray, t: float, tolerance_s: float) -> int | None:
    if not len(times) or not np.isfinite(t):
        return None
    k = int(np.argmin(np.abs(times - t)))
    return k if abs(times[k] - t) <= tolerance_s else None


def check_events(report, truth: GaitTruth, *, tolerance_s: float = TOLERANCE_S) -> EventCheck:
    """The :class:`EventCheck` of a ``GaitReport`` against ``truth`` (same clock)."""
    problems: list[str] = []
    hs = {f: np.asarray(truth.heel_strike_s[f]) for f in ("left", "right")}
    found = {f: np.array([c.heel_strike_s for c in report.contacts if c.valid and c.foot == f]) for f in hs}
    missed_in_pass = 0
    for p in report.passes:
        for f in hs:
            for t in hs[f][(hs[f] >= p.start_s) & (hs[f] <= p.end_s)]:
                if _nearest(found[f], t, tolerance_s) is None:
                    missed_in_pass += 1
                    problems.append(f"pass {p.index}: true {f} heel strike at {t:.2f} s not found")
    made_up = toe_off = negative = 0
    for s in report.steps:
        k = _nearest(hs[s.foot], s.heel_strike_s, tolerance_s)
        if k is None:
            made_up += 1
            problems.append(f"{s.foot} step at {s.heel_strike_s:.2f} s: no true heel strike of that foot near it")
        elif np.isfinite(s.toe_off_s):
            nxt = hs[s.foot][k + 1] if k + 1 < len(hs[s.foot]) else np.inf
            if not s.heel_strike_s < s.toe_off_s < nxt:
                toe_off += 1
                problems.append(f"{s.foot} step at {s.heel_strike_s:.2f} s: toe off at {s.toe_off_s:.2f} s outside "
                                f"its stance (next true heel strike {nxt:.2f} s)")
        if np.isfinite(s.step_length_mm) and s.step_length_mm <= 0:
            negative += 1
            problems.append(f"{s.foot} step at {s.heel_strike_s:.2f} s: step length {s.step_length_mm:.0f} mm")
    dropped = [o for o in report.left_out if o.what == "dropped step"]
    for o in dropped:
        if "_mm -" in o.why:
            negative += 1
            problems.append(o.why)
    summary = report.summary
    return EventCheck(
        steps=len(report.steps), counted=summary.num_steps - summary.num_edge_steps - summary.num_excluded_steps,
        excluded=sum(bool(s.excluded) for s in report.steps),
        missed_contacts=sum(o.what == "missed contact" for o in report.left_out), dropped_steps=len(dropped),
        missed_in_pass=missed_in_pass, made_up=made_up, toe_off_outside_stance=toe_off, negative_steps=negative,
        problems=tuple(problems))
