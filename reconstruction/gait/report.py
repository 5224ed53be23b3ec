"""GaitReport: everything gait analysis found in one trial, serialisable to JSON and CSV."""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
from dataclasses import dataclass
from typing import Any

from gaitcap.reconstruction.gait.bouts import Pass, Segment
from gaitcap.reconstruction.gait.events import Contact, EventTiming
from gaitcap.reconstruction.gait.parameters import STEP_PARAMETERS, GaitSummary, LeftOut, Step
from gaitcap.reconstruction.gait.walkway import WalkwayComparison
from gaitcap.reconstruction.jsonable import json_ready

CSV_COLUMNS = (
    "index", "pass_index", "foot", "heel_strike_s", "toe_off_s", "heel_x_mm", "heel_y_mm", "heel_z_mm",
    "toe_x_mm", "toe_y_mm", "toe_z_mm", *STEP_PARAMETERS, "confidence", "steady", "low_confidence", "excluded",
)
SUMMARY_CSV_COLUMNS = ("parameter", "side", "n", "mean", "sd", "cv_pct", "symmetry_index_pct")


@dataclass(frozen=True)
class GaitReport:
    """Gait analysis of one trial.

    Attributes:
        steps: analysed steps (see ``parameters.Step``; mm, s, % of cycle), those not counted in the
            summary with the reason (``Step.excluded``).
        summary: cadence, speed, per-side statistics and asymmetry.
        passes: straight passes with their direction of progression.
        segments: the trial split into pass / turn / standing / gap (s).
        contacts: every detected foot contact, including those in turns (s, mm).
        warnings: human-readable notes on what was excluded and why.
        walkway: comparison with a walkway export, when one was given.
        timing: how finely the events are located (sub-frame on a continuous trajectory, one frame
            interval on a frame-grid one such as the preliminary triangulation); None if not given.
        left_out: the steps no step could be formed for in a pass (missed contacts, dropped steps), with why.
    """

    steps: tuple[Step, ...]
    summary: GaitSummary
    passes: tuple[Pass, ...]
    segments: tuple[Segment, ...]
    contacts: tuple[Contact, ...]
    warnings: tuple[str, ...] = ()
    walkway: WalkwayComparison | None = None
    timing: EventTiming | None = None
    left_out: tuple[LeftOut, ...] = ()

    def with_walkway(self, comparison: WalkwayComparison) -> GaitReport:
        return dataclasses.replace(self, walkway=comparison)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict: steps (list of objects), summary, passes, segments, contacts, warnings,
        walkway (or None), timing (``EventTiming``'s fields). NaN values become None."""
        return json_ready(self)

    def to_json(self, **kwargs: Any) -> str:
        return json.dumps(self.to_dict(), allow_nan=False, **kwargs)

    def to_csv(self) -> str:
        """One row per step, columns ``CSV_COLUMNS`` (empty cell for NaN)."""
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(CSV_COLUMNS)
        for s in self.steps:
            row = [s.index, s.pass_index, s.foot, s.heel_strike_s, s.toe_off_s, *s.heel_mm, *s.toe_mm,
                   *(getattr(s, p) for p in STEP_PARAMETERS), s.confidence, int(s.steady), int(s.low_confidence),
                   s.excluded]
            writer.writerow(_cells(row))
        return buf.getvalue()

    def to_summary_csv(self) -> str:
        """Per-side statistics of the steady steps: one row per parameter and side ("all", "left",
        "right"), columns ``SUMMARY_CSV_COLUMNS`` (units those of the parameter; the symmetry index of
        ``GaitSummary.asymmetry_pct`` on every row of its parameter)."""
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(SUMMARY_CSV_COLUMNS)
        for name, groups in self.summary.parameters.items():
            for side, st in groups.items():
                writer.writerow(_cells([name, side, st.n, st.mean, st.sd, st.cv_pct,
                                        self.summary.asymmetry_pct.get(name, float("nan"))]))
        return buf.getvalue()


def _cells(row: list) -> list:
    """CSV cells: empty for NaN, 6 significant digits for floats."""
    return ["" if isinstance(v, float) and not math.isfinite(v) else (f"{v:.6g}" if isinstance(v, float) else v)
            for v in row]
