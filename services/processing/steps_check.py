"""The ``steps`` check of a trial's quality block: the steps a stage's gait analysis could not count.

Missed contacts (two contacts of one foot in a row), dropped steps (a length no walking step has) and
steps excluded from the summary (events out of order, a broken left/right sequence, a value implausible
for this patient: :mod:`gaitcap.reconstruction.gait.plausibility`) are the trial's warnings, so the page
never says that every check passed beside them. Each stage replaces the previous stage's check (the
numbers shown are the last stage's); the check names its stage.
"""

from __future__ import annotations

from gaitcap.reconstruction.jsonable import json_ready

STAGE_WORDS = {"preliminary": "The preliminary analysis", "refined": "The refined analysis"}


def _stage(stage: str) -> str:
    return STAGE_WORDS.get(stage, f"The {stage} analysis")


def steps_check(stage: str, report) -> dict:
    """The check of a stage's ``GaitReport`` (None: no gait analysis, nothing to say): ``stage``,
    ``excluded`` (index, foot, time_s, why), ``missed_contacts`` and ``dropped_steps`` (foot, time_s, why),
    ``counted`` (steps in the summary), ``warnings`` (plain words) and ``notes``."""
    if report is None:
        return {"stage": stage, "excluded": [], "missed_contacts": [], "dropped_steps": [], "counted": 0,
                "warnings": [], "notes": []}
    excluded = [{"index": s.index, "foot": s.foot, "time_s": round(s.heel_strike_s, 3), "why": s.excluded}
                for s in report.steps if s.excluded]
    missed = [o for o in report.left_out if o.what == "missed contact"]
    dropped = [o for o in report.left_out if o.what == "dropped step"]
    who, warnings = _stage(stage), []
    if excluded:
        warnings.append(f"{who} did not count {len(excluded)} step{'s' * (len(excluded) != 1)} in the summary: "
                        + "; ".join(f"{e['foot']} step at {e['time_s']:.2f} s ({e['why']})" for e in excluded))
    if missed:
        warnings.append(f"{who} missed {len(missed)} foot contact{'s' * (len(missed) != 1)}: "
                        + "; ".join(o.why for o in missed))
    if dropped:
        warnings.append(f"{who} dropped {len(dropped)} step{'s' * (len(dropped) != 1)} with a length no walking "
                        "step has: " + "; ".join(o.why for o in dropped))
    counted = report.summary.num_steps - report.summary.num_edge_steps - report.summary.num_excluded_steps
    return {"stage": stage, "excluded": excluded, "missed_contacts": [json_ready(o) for o in missed],
            "dropped_steps": [json_ready(o) for o in dropped], "counted": int(counted), "warnings": warnings,
            "notes": []}
