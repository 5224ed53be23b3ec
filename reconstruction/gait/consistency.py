"""Consistency rules of a trial's spatiotemporal parameters: numbers that must agree with each other.

Before a parameter is shown or printed as a clinical finding, the arithmetic that ties the parameters
together must hold (see ``parameters`` for the definitions):

- ``stance_support``: per side, stance = single support + double support (s and % of the cycle);
- ``cycle_percentages``: per side, stance % + swing % = 100 % (and stance + swing = stride time, s);
- ``steps_make_stride``: the left and the right step time add up to the stride time (per step: this
  step's time and the previous opposite step's time make this step's stride);
- ``cadence_step_time``: cadence = 60 / mean step time;
- ``single_support_swing``: one side's single support is the other side's swing (means, s).

Each comparison is allowed one frame period of difference (an event is located to about a frame), in
the parameter's unit: ``frame_period_s`` for times, ``100 frame_period_s / stride time`` for % of the
cycle and ``60 frame_period_s / step time^2`` steps/min for cadence (plus 2 ms for values stored rounded).
Means taken over different steps (the stride and the two step times; one side's single support and the
other side's swing) are allowed twice the standard error of their difference on top. A rule that fails is a data problem
(events detected wrongly, values measured on different steps), never a clinical finding: the report's
``parameters_in_doubt`` names the parameters whose values must not be read as findings.

Inputs are JSON shapes (what ``GaitReport.to_dict()`` and the catalog store): a summary either per side
(``{"parameters": {name: {"left"|"right"|"all": {"n", "mean", ...}}}, "cadence_steps_min": x}``) or
pooled (``{name: {"mean": x}, "cadence_steps_per_min": {"mean": x}}``), and steps as dicts with
``foot`` (or ``side``), ``heel_strike_s`` (or ``time_s``), ``pass_index`` (or ``pass_no``) and the
parameters they hold. A rule whose values are absent is listed as not checked. Pure computation.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

SIDES = ("left", "right")
OTHER = {"left": "right", "right": "left"}
#: Allowed difference beyond the frame period: what rounding of stored values (3 decimals) can add.
ROUNDING = 2e-3


def _parameter(key: str) -> str:
    """The parameter a value's key names: ``previous_left_step_time_s`` -> ``step_time_s``."""
    for prefix in ("previous_", "left_", "right_"):
        key = key.removeprefix(prefix)
    return key


def _label(name: str) -> str:
    """``stance_pct`` -> "stance %", ``left_swing_time_s`` -> "left swing time"."""
    for suffix, unit in (("_pct", " %"), ("_s", ""), ("_min", "")):
        if name.endswith(suffix):
            name = name[: -len(suffix)] + unit
            break
    return name.replace("_", " ")


@dataclass(frozen=True)
class Failure:
    """One comparison that did not hold.

    Attributes:
        rule: the rule's name (see the module docstring).
        parameter: the parameter compared (e.g. ``stance_time_s``).
        side: "left", "right" or "all".
        expected: what the other parameters make it (``parameter``'s unit).
        found: the parameter's value.
        tolerance: the difference allowed (same unit).
        unit: "s", "% cycle" or "steps/min".
        values: every value that entered the comparison (name -> value).
        step_index: the step's index for a per-step comparison, None for the summary.
        time_s: that step's heel strike (s), None for the summary.
    """

    rule: str
    parameter: str
    side: str
    expected: float
    found: float
    tolerance: float
    unit: str
    values: dict[str, float]
    step_index: int | None = None
    time_s: float | None = None

    @property
    def message(self) -> str:
        where = (f"{self.side} step at {self.time_s:.2f} s" if self.time_s is not None
                 else ("mean" if self.side == "all" else f"{self.side} mean"))
        terms = ", ".join(f"{_label(k)} {v:.3f}" for k, v in self.values.items())
        return (f"{RULES[self.rule].description} does not hold ({where}): {_label(self.parameter)} "
                f"{self.found:.3f} {self.unit} but {self.expected:.3f} {self.unit} from the others ({terms}); "
                f"allowed difference {self.tolerance:.3f} {self.unit}")

    def to_dict(self) -> dict[str, Any]:
        return {"rule": self.rule, "parameter": self.parameter, "side": self.side, "expected": self.expected,
                "found": self.found, "tolerance": self.tolerance, "unit": self.unit, "values": dict(self.values),
                "step_index": self.step_index, "time_s": self.time_s, "message": self.message}


@dataclass(frozen=True)
class ConsistencyReport:
    """The rules run on one trial's parameters.

    Attributes:
        frame_period_s: the frame period the tolerances come from (s).
        rules_checked: names of the rules that compared at least one pair of values.
        rules_not_checked: rule name -> why it compared nothing (values absent).
        comparisons: how many comparisons were made.
        failures: the comparisons that did not hold.
    """

    frame_period_s: float
    rules_checked: tuple[str, ...]
    rules_not_checked: dict[str, str]
    comparisons: int
    failures: tuple[Failure, ...] = field(default_factory=tuple)

    @property
    def ok(self) -> bool:
        return not self.failures

    @property
    def parameters_in_doubt(self) -> frozenset[str]:
        """Every parameter that entered a failing comparison: not to be read as a clinical finding."""
        return frozenset(_parameter(name) for f in self.failures for name in (f.parameter, *f.values))

    def to_dict(self) -> dict[str, Any]:
        return {"ok": self.ok, "frame_period_s": self.frame_period_s, "rules_checked": list(self.rules_checked),
                "rules_not_checked": dict(self.rules_not_checked), "comparisons": self.comparisons,
                "parameters_in_doubt": sorted(self.parameters_in_doubt),
                "failures": [f.to_dict() for f in self.failures]}


# ------------------------------------------------------------------------------------------ normalised input
@dataclass(frozen=True)
class _Trial:
    """Means by (parameter, side) and steps as (index, side, time_s, pass, values) with finite values only."""

    means: dict[tuple[str, str], float]
    spreads: dict[tuple[str, str], float]  # squared standard error of the mean (sd^2 / n), where known
    steps: tuple[tuple[int, str, float, int, dict[str, float]], ...]
    frame_period_s: float

    def mean(self, name: str, side: str) -> float:
        return self.means.get((name, side), math.nan)

    def across_steps(self, *keys: tuple[str, str]) -> float:
        """Tolerance (the unit of the keys' parameters) of a comparison of means taken over different
        steps: the frame period and rounding plus twice the standard error of their sum or difference."""
        return self.frame_period_s + ROUNDING + 2.0 * math.sqrt(sum(self.spreads.get(k, 0.0) for k in keys))


def _finite(x: Any) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return math.nan
    return v if math.isfinite(v) else math.nan


def _spreads(summary: Mapping[str, Any]) -> dict[tuple[str, str], float]:
    out = {}
    for name, groups in (summary.get("parameters") or {}).items():
        for side, stats in (groups or {}).items():
            sd, n = _finite((stats or {}).get("sd")), _finite((stats or {}).get("n"))
            if math.isfinite(sd) and n > 0:
                out[(name, side)] = sd * sd / n
    return out


def _means(summary: Mapping[str, Any]) -> dict[tuple[str, str], float]:
    out: dict[tuple[str, str], float] = {}
    for name, groups in (summary.get("parameters") or {}).items():
        for side, stats in (groups or {}).items():
            out[(name, side)] = _finite((stats or {}).get("mean"))
    for name, value in summary.items():
        if isinstance(value, Mapping) and "mean" in value:  # the catalog's pooled summary
            out.setdefault((name, "all"), _finite(value.get("mean")))
    cadence = summary.get("cadence_steps_min")
    if cadence is None:
        cadence = (summary.get("cadence_steps_per_min") or {}).get("mean")
    out[("cadence_steps_min", "all")] = _finite(cadence)
    return {k: v for k, v in out.items() if math.isfinite(v)}


def _steps(steps: Iterable[Mapping[str, Any]]) -> tuple:
    out = []
    for i, s in enumerate(steps):
        side = s.get("foot") or s.get("side")
        time_s = _finite(s.get("heel_strike_s", s.get("time_s")))
        pass_no = s.get("pass_index", s.get("pass_no"))
        values = {k: _finite(v) for k, v in s.items() if isinstance(v, int | float) and not isinstance(v, bool)}
        out.append((int(s.get("index", i)), str(side), time_s, pass_no,
                    {k: v for k, v in values.items() if math.isfinite(v)}))
    return tuple(out)


# ----------------------------------------------------------------------------------------------- the rules
@dataclass(frozen=True)
class _Comparison:
    parameter: str
    side: str
    expected: float
    found: float
    tolerance: float
    unit: str
    values: dict[str, float]
    step_index: int | None = None
    time_s: float | None = None


def _pct_tolerance(frame_period_s: float, stride_s: float) -> float:
    return 100.0 * (frame_period_s + ROUNDING) / stride_s if stride_s > 0 else math.nan


def _stance_support(t: _Trial) -> list[_Comparison]:
    out = []
    for side in SIDES:
        stride = t.mean("stride_time_s", side)
        for unit, names, tol in (("s", ("stance_time_s", "single_support_s", "double_support_s"),
                                  t.frame_period_s + ROUNDING),
                                 ("% cycle", ("stance_pct", "single_support_pct", "double_support_pct"),
                                  _pct_tolerance(t.frame_period_s, stride))):
            stance, single, double = (t.mean(n, side) for n in names)
            if all(map(math.isfinite, (stance, single, double, tol))):
                out.append(_Comparison(names[0], side, single + double, stance, tol, unit,
                                       {names[1]: single, names[2]: double}))
    for index, side, time_s, _, v in t.steps:
        names = ("stance_time_s", "single_support_s", "double_support_s")
        if all(n in v for n in names):
            out.append(_Comparison(names[0], side, v[names[1]] + v[names[2]], v[names[0]],
                                   t.frame_period_s + ROUNDING, "s", {n: v[n] for n in names[1:]}, index, time_s))
    return out


def _cycle_percentages(t: _Trial) -> list[_Comparison]:
    out = []
    for side in SIDES:
        stance, swing, stride = (t.mean(n, side) for n in ("stance_pct", "swing_pct", "stride_time_s"))
        tol = _pct_tolerance(t.frame_period_s, stride)
        if all(map(math.isfinite, (stance, swing, tol))):
            out.append(_Comparison("swing_pct", side, 100.0 - stance, swing, tol, "% cycle", {"stance_pct": stance}))
    for index, side, time_s, _, v in t.steps:
        if all(n in v for n in ("stance_time_s", "swing_time_s", "stride_time_s")):
            out.append(_Comparison("stride_time_s", side, v["stance_time_s"] + v["swing_time_s"], v["stride_time_s"],
                                   t.frame_period_s + ROUNDING, "s",
                                   {"stance_time_s": v["stance_time_s"], "swing_time_s": v["swing_time_s"]},
                                   index, time_s))
        if all(n in v for n in ("stance_pct", "swing_pct", "stride_time_s")):
            out.append(_Comparison("swing_pct", side, 100.0 - v["stance_pct"], v["swing_pct"],
                                   _pct_tolerance(t.frame_period_s, v["stride_time_s"]), "% cycle",
                                   {"stance_pct": v["stance_pct"]}, index, time_s))
    return out


def _steps_make_stride(t: _Trial) -> list[_Comparison]:
    out = []
    left, right = t.mean("step_time_s", "left"), t.mean("step_time_s", "right")
    for side in (*SIDES, "all"):
        stride = t.mean("stride_time_s", side)
        if all(map(math.isfinite, (left, right, stride))):
            tol = t.across_steps(("step_time_s", "left"), ("step_time_s", "right"), ("stride_time_s", side))
            out.append(_Comparison("stride_time_s", side, left + right, stride, tol, "s",
                                   {"left_step_time_s": left, "right_step_time_s": right}))
    for prev, step in zip(t.steps[:-1], t.steps[1:], strict=True):
        (_, side0, time0, pass0, v0), (index, side, time_s, pass_no, v) = prev, step
        follows = (side0 != side and pass0 == pass_no and "step_time_s" in v
                   and abs(time_s - v["step_time_s"] - time0) <= t.frame_period_s / 2 + ROUNDING)
        if follows and "stride_time_s" in v and "step_time_s" in v0:
            out.append(_Comparison("stride_time_s", side, v["step_time_s"] + v0["step_time_s"], v["stride_time_s"],
                                   t.frame_period_s + ROUNDING, "s",
                                   {"step_time_s": v["step_time_s"], f"previous_{side0}_step_time_s": v0["step_time_s"]},
                                   index, time_s))
    return out


def _cadence_step_time(t: _Trial) -> list[_Comparison]:
    cadence, step = t.mean("cadence_steps_min", "all"), t.mean("step_time_s", "all")
    if not (math.isfinite(cadence) and math.isfinite(step) and step > 0):
        return []
    tol = 60.0 * (t.frame_period_s + ROUNDING) / step**2
    return [_Comparison("cadence_steps_min", "all", 60.0 / step, cadence, tol, "steps/min", {"step_time_s": step})]


def _single_support_swing(t: _Trial) -> list[_Comparison]:
    out = []
    for side in SIDES:
        single, swing = t.mean("single_support_s", side), t.mean("swing_time_s", OTHER[side])
        if math.isfinite(single) and math.isfinite(swing):
            tol = t.across_steps(("single_support_s", side), ("swing_time_s", OTHER[side]))
            out.append(_Comparison("single_support_s", side, swing, single, tol, "s",
                                   {f"{OTHER[side]}_swing_time_s": swing}))
    return out


@dataclass(frozen=True)
class Rule:
    """A consistency rule: what it says and the comparisons it makes on a trial."""

    description: str
    compare: Callable[[_Trial], list[_Comparison]]


#: The rules, by name (the order they run and are reported in).
RULES: dict[str, Rule] = {
    "stance_support": Rule("stance = single support + double support", _stance_support),
    "cycle_percentages": Rule("stance + swing = the whole cycle", _cycle_percentages),
    "steps_make_stride": Rule("left + right step time = stride time", _steps_make_stride),
    "cadence_step_time": Rule("cadence = 60 / mean step time", _cadence_step_time),
    "single_support_swing": Rule("single support = the other side's swing", _single_support_swing),
}


def check_consistency(summary: Mapping[str, Any], steps: Sequence[Mapping[str, Any]] = (), *,
                      frame_period_s: float) -> ConsistencyReport:
    """Run every rule of :data:`RULES` on a trial's summary and steps (JSON shapes, see the module
    docstring); ``frame_period_s`` (s, > 0) sets the tolerances. ValueError for a bad frame period."""
    if not (isinstance(frame_period_s, int | float) and math.isfinite(frame_period_s) and 0 < frame_period_s < 1):
        raise ValueError(f"frame_period_s: must be a frame period in (0, 1) s, got {frame_period_s!r}")
    trial = _Trial(_means(summary or {}), _spreads(summary or {}), _steps(steps or ()), float(frame_period_s))
    checked, not_checked, failures, count = [], {}, [], 0
    for name, rule in RULES.items():
        comparisons = rule.compare(trial)
        if not comparisons:
            not_checked[name] = "the values it compares were not measured"
            continue
        checked.append(name)
        count += len(comparisons)
        failures += [Failure(name, c.parameter, c.side, c.expected, c.found, c.tolerance, c.unit, c.values,
                             c.step_index, c.time_s)
                     for c in comparisons if not abs(c.found - c.expected) <= c.tolerance]
    return ConsistencyReport(float(frame_period_s), tuple(checked), not_checked, count, tuple(failures))


def check_report(report, *, frame_period_s: float) -> ConsistencyReport:
    """:func:`check_consistency` of a ``GaitReport`` (its summary and steps)."""
    data = report.to_dict()
    return check_consistency(data["summary"], data["steps"], frame_period_s=frame_period_s)
