"""What the page and the report may say about a trial's numbers: findings only against a norm, only on
numbers that passed the consistency rules, and a count of what had a reference.

- A value is called outside the normal range only when the normative table has a row for it (and its
  z-score is beyond +-1.96); nothing is ever called "normal" without a row. ``norm_summary`` says how many
  parameters had one ("6 of 15 parameters have a normal range for age and sex; none outside it").
- A parameter that entered a failed consistency rule (:mod:`gaitcap.reconstruction.gait.consistency`) is a
  data problem: it gets no finding (neither outside the range nor a side difference), and the failure is
  listed in plain words among the data problems.
- A finding rests only on numbers that hold: with the stage's steps (``held``), each side needs
  ``MIN_STEPS_PER_SIDE`` counted steps and the finding must survive leaving out any single step
  (:mod:`gaitcap.reconstruction.gait.stability`); one that does not is ``withheld`` (the numbers stated,
  no finding). The preliminary stage's findings say "Preliminary".
- The consistency block is the stage's stored one (key ``consistency`` of the result's report or quality
  block) when the processing stored it, else computed here from the stage's ``gait.json`` summary and
  steps with the trial's frame period (``data_quality.nominal_fps``; 30 fps when unknown).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

from gaitcap.reconstruction.gait.consistency import check_consistency
from gaitcap.reconstruction.gait.stability import (
    MIN_CYCLES_PER_SIDE,
    MIN_STEPS_PER_SIDE,
    Held,
    loo_mean_range,
)
from gaitcap.reconstruction.kinematics.clinical import KEY_VALUES, key_label
from gaitcap.reconstruction.kinematics.key_norms import NO_REFERENCE, KeyNorm, key_norms, no_reference

DEFAULT_FPS = 30.0
SIDE_DIFFERENCE_PCT = 10.0  # symmetry index above which sides are said to differ
Z_OUTSIDE = 1.96


class _Row(Protocol):  # services.reports.content.Row
    name: str
    left: float
    right: float
    mean: float
    si_pct: float
    norm: Any

    @property
    def z(self) -> float: ...


@dataclass(frozen=True)
class Labelled:
    """How a parameter is named in a sentence: label, unit, decimals."""

    label: str
    unit: str
    decimals: int


@dataclass(frozen=True)
class Findings:
    """What may be said of a trial's parameters.

    Attributes:
        findings: values outside their normal range, sides differing by more than 10 %.
        data_problems: consistency rules that failed (plain words): not findings.
        norm_summary: how many parameters had a normal range and how many lie outside it.
        with_reference: parameters with a normal range for the patient (and a measured value).
        outside: of those, the ones outside it.
        in_doubt: parameters that entered a failed rule (no finding is made on them).
        withheld: side differences and values outside a range that do not hold (too few counted steps a
            side, or gone when one step is left out: :mod:`gaitcap.reconstruction.gait.stability`), in plain
            words: stated as numbers, never as findings.
        unstable: the parameters of ``withheld``.
    """

    findings: tuple[str, ...]
    data_problems: tuple[str, ...]
    norm_summary: str
    with_reference: int
    total: int
    outside: int
    in_doubt: frozenset[str]
    withheld: tuple[str, ...] = ()
    unstable: frozenset[str] = frozenset()

    def to_dict(self) -> dict[str, Any]:
        return {"findings": list(self.findings), "data_problems": list(self.data_problems),
                "norm_summary": self.norm_summary, "with_reference": self.with_reference, "total": self.total,
                "outside": self.outside, "in_doubt": sorted(self.in_doubt), "withheld": list(self.withheld),
                "unstable": sorted(self.unstable)}


def frame_period_s(data_quality: Mapping[str, Any] | None) -> float:
    """The trial's frame period (s) from its data-quality block's ``nominal_fps``; 1/30 s when unknown."""
    fps = (data_quality or {}).get("nominal_fps")
    return 1.0 / fps if isinstance(fps, int | float) and math.isfinite(fps) and 5 <= fps <= 1000 else 1.0 / DEFAULT_FPS


def consistency_of(stored: Mapping[str, Any] | None, gait: Mapping[str, Any] | None,
                   data_quality: Mapping[str, Any] | None) -> dict[str, Any]:
    """The stage's consistency block: ``stored`` when the processing stored one, else computed from the
    stage's ``gait.json`` (``summary`` and ``steps``); an empty check when there is no gait file."""
    if stored and isinstance(stored.get("failures"), list):
        return dict(stored)
    gait = gait or {}
    return check_consistency(gait.get("summary") or {}, gait.get("steps") or [],
                             frame_period_s=frame_period_s(data_quality)).to_dict()


def outage_problem(data_quality: Mapping[str, Any] | None) -> str:
    """A camera outage during the trial (the recorder's Start-Stop time exceeds the time with images by
    more than ``NO_IMAGES_S``) as a data problem: the walk there is missing from the numbers; "" when none."""
    from gaitcap.services.processing.quality import NO_IMAGES_S

    q = data_quality or {}
    recorded, imaged = q.get("recorded_s"), q.get("duration_s")
    if not (isinstance(recorded, int | float) and isinstance(imaged, int | float)) or recorded - imaged <= NO_IMAGES_S:
        return ""
    return (f"Data problem, not a clinical finding: no camera images for {recorded - imaged:.1f} s of the "
            f"{recorded:.1f} s between Start and Stop; the walking of that time is missing from these numbers, "
            "which may not represent the whole walk.")


def plain_problem(failure: Mapping[str, Any]) -> str:
    """A failed rule as a data problem the clinician can read (the message, stated as not a finding)."""
    return f"Data problem, not a clinical finding: {failure.get('message') or failure.get('rule')}."


def findings_of(rows: Sequence[_Row], consistency: Mapping[str, Any],
                labels: Mapping[str, Labelled], *, not_recorded: str = "",
                held: Mapping[str, Held] | None = None, prefix: str = "") -> Findings:
    """Findings of the report rows (``content.Row``: mean, sides, symmetry, norm row) against their norms,
    leaving out the parameters in doubt by ``consistency`` (a :class:`ConsistencyReport` dict);
    ``not_recorded``: what of the patient the norms need is not recorded ("sex and birth year not recorded").
    ``held``: each parameter's leave-one-out over the stage's counted steps
    (:func:`gaitcap.reconstruction.gait.stability.leave_one_out`): a finding is made only where it holds
    (enough steps a side, and whichever single step is left out); the others are ``withheld``. None: the
    rows are judged alone (a table without steps). ``prefix``: put before each finding ("Preliminary: ")."""
    doubt = frozenset(consistency.get("parameters_in_doubt") or ())
    out, withheld, unstable, outside, referenced = [], [], set(), 0, 0
    measured = [r for r in rows if math.isfinite(r.mean)]
    for r in rows:
        p = labels[r.name]
        if r.name in doubt:
            continue
        rests = _rests_on(r, held)
        if r.norm is not None and math.isfinite(r.mean):
            referenced += 1
            if math.isfinite(r.z) and abs(r.z) > Z_OUTSIDE:
                lo, hi = r.norm.band()
                said = (f"{p.label} {r.mean:.{p.decimals}f} {p.unit} is {'below' if r.z < 0 else 'above'} the "
                        f"normal range for age and sex ({lo:.{p.decimals}f}-{hi:.{p.decimals}f} {p.unit}).")
                why = (rests or _unheld(held[r.name], p, lambda v, n=r.norm: _outside(n, v))) if held is not None else ""
                if why:
                    withheld.append(f"Not a finding: {said[:-1]}, but {why}.")
                    unstable.add(r.name)
                else:
                    outside += 1
                    out.append(prefix + said)
        if math.isfinite(r.si_pct) and r.si_pct > SIDE_DIFFERENCE_PCT:
            said = (f"{p.label} differs between sides: left {r.left:.{p.decimals}f}, right "
                    f"{r.right:.{p.decimals}f} {p.unit} (symmetry index {r.si_pct:.1f} %).")
            why = (rests or _unheld(held[r.name], p, None)) if held is not None else ""
            if why:
                withheld.append(f"Not a finding: {said[:-1]}, but {why}.")
                unstable.add(r.name)
            else:
                out.append(prefix + said)
    problems = tuple(plain_problem(f) for f in consistency.get("failures") or ())
    summary = norm_summary(referenced, len(measured), outside, len(doubt & {r.name for r in rows}),
                           not_recorded=not_recorded)
    return Findings(tuple(out), problems, summary, referenced, len(measured), outside, doubt, tuple(withheld),
                    frozenset(unstable))


def _outside(norm, value: float) -> int:
    """-1 below the norm's normal range, +1 above, 0 inside."""
    z = norm.z(value)
    return 0 if not (math.isfinite(z) and abs(z) > Z_OUTSIDE) else (-1 if z < 0 else 1)


def _rests_on(row: _Row, held: Mapping[str, Held] | None) -> str:
    """Why the row's numbers are not those of the counted steps ("" when they are, or ``held`` is None)."""
    if held is None:
        return ""
    h = held.get(row.name)
    if h is not None and not h.enough:
        return ""  # said by _unheld: too few counted steps
    if h is None or not h.agrees(left=row.left, right=row.right, mean=row.mean):
        return "these numbers are not those of the counted steps"
    return ""


def _unheld(h: Held, p: Labelled, outside) -> str:
    """Why a side difference (``outside`` None) or a value outside a range (``outside(value)``: -1, 0, +1)
    does not hold ("" when it does)."""
    if not h.enough:
        return (f"too few counted steps to say it ({h.n_left} left, {h.n_right} right; at least "
                f"{MIN_STEPS_PER_SIDE} a side)")
    if outside is None:
        if h.side_difference_holds(SIDE_DIFFERENCE_PCT):
            return ""
        lo, hi = h.si_range
        return f"it rests on single steps (symmetry index {lo:.1f}-{hi:.1f} % leaving out one step at a time)"
    if h.beyond(outside):
        return ""
    lo, hi = h.mean_range
    return (f"it rests on single steps ({lo:.{p.decimals}f}-{hi:.{p.decimals}f} {p.unit} leaving out one step "
            "at a time)")


def norm_summary(with_reference: int, total: int, outside: int, in_doubt: int = 0, *, not_recorded: str = "") -> str:
    """"6 of 15 parameters have a normal range for age and sex; none outside it." Without any range it says
    "No reference for this patient" (and what is not recorded) and that no value is called normal or
    abnormal."""
    doubt = (f" {in_doubt} parameter{'s' * (in_doubt != 1)} with a data problem not compared."
             if in_doubt else "")
    if with_reference == 0:
        why = f" ({not_recorded})" if not_recorded else " (the normative table has no normal range for this age and sex)"
        return (f"No reference for this patient{why}: none of the {total} parameters has a normal range, no "
                f"value is called normal or abnormal.{doubt}")
    verdict = "none outside it" if outside == 0 else f"{outside} outside it"
    have = "has" if with_reference == 1 else "have"
    return f"{with_reference} of {total} parameters {have} a normal range for age and sex; {verdict}.{doubt}"


@dataclass(frozen=True)
class KeyValueFindings:
    """Joint-angle key values against the band: findings, how many values (per side) had a normal range
    (a z-score), how many were measured, how many lie outside (as findings); the norms by key value name.
    ``withheld``: values outside the range that do not hold (too few gait cycles on that side, or gone when
    one cycle is left out), in plain words: stated as numbers, never as findings."""

    findings: tuple[str, ...]
    with_reference: int
    total: int
    outside: int
    norms: dict[str, KeyNorm]
    no_reference: tuple[str, ...] = ()  # variables whose zero is not validated (key_norms.UNVALIDATED_ZERO)
    patient: str = ""  # "no reference for this patient: ..." (no band describes this patient), else ""
    withheld: tuple[str, ...] = ()

    @property
    def summary(self) -> str:
        if not self.total:
            return ""
        if self.patient:
            return (f"Joint angles: {self.patient[0].upper()}{self.patient[1:]}; no key value is called normal "
                    "or abnormal.")
        unvalidated = (f" {' and '.join(v.replace('_', ' ') for v in self.no_reference).capitalize()}: "
                       f"{NO_REFERENCE}." if self.no_reference else "")
        if not self.with_reference:
            return ("Joint angles: no key value has a normal range (no band), none is called normal or abnormal."
                    + unvalidated)
        verdict = "none outside it" if not self.outside else f"{self.outside} outside it"
        return (f"Joint angles: {self.with_reference} of {self.total} key values (per side) have a normal range "
                f"from the band; {verdict}.{unvalidated}")


def key_value_label(name: str) -> str:
    """The key value's label with its sign convention (:data:`gaitcap.reconstruction.kinematics.clinical.KEY_LABELS`)."""
    return key_label(name)


def _outside_text(name: str, norm: KeyNorm, off: list[str]) -> str:
    if math.isfinite(norm.lower_deg):  # a range of motion: one-sided
        return (f"{key_value_label(name)}: {', '.join(off)} deg, below the normal range (at least "
                f"{norm.lower_deg:.1f} deg; the band's range of motion is {norm.normal_deg:.1f} deg).")
    lo, hi = norm.band()
    return (f"{key_value_label(name)}: {', '.join(off)} deg, outside the normal range {lo:.1f} to {hi:.1f} deg "
            f"of the band at {norm.at_pct} % of the cycle.")


def _cycles_unheld(stats: Mapping[str, Any], norm: KeyNorm, verdict: int) -> str:
    """Why one side's key value outside the range (``verdict``: -1 below, +1 above) is no finding: too few
    gait cycles on that side, per-cycle values that are not the mean shown, or a verdict that changes when
    one cycle is left out ("" when it holds: the same rule as the spatiotemporal findings',
    :mod:`gaitcap.reconstruction.gait.stability`)."""
    raw = stats.get("values")
    cycles = [_finite(v) for v in raw] if isinstance(raw, list) else []
    cycles = [v for v in cycles if math.isfinite(v)]
    if len(cycles) < MIN_CYCLES_PER_SIDE:
        return (f"too few gait cycles to say it ({len(cycles)} on this side; at least {MIN_CYCLES_PER_SIDE} a "
                "side)")
    mean = _finite(stats.get("mean"))
    if abs(sum(cycles) / len(cycles) - mean) > 1e-6 * max(1.0, abs(mean)):
        return "these numbers are not those of the gait cycles"
    lo, hi = loo_mean_range(cycles)
    if norm.verdict(lo) == verdict and norm.verdict(hi) == verdict:
        return ""
    return f"it rests on single cycles ({lo:.1f} to {hi:.1f} deg leaving out one cycle at a time)"


def key_value_findings(kinematics: Mapping[str, Any] | None) -> KeyValueFindings:
    """Each side's key joint-angle values (``kinematics.json`` with the band chosen for the patient) against
    the band (:mod:`gaitcap.reconstruction.kinematics.key_norms`): a finding per value outside the normal
    range (|z| > 1.96; a range of motion below its one-sided lower limit), both sides in one sentence, made
    only where it holds: at least ``MIN_CYCLES_PER_SIDE`` gait cycles on that side (the per-cycle
    ``values``) and outside on the same side of the range whichever single cycle is left out; the others
    are ``withheld``."""
    k = kinematics or {}
    kv = k.get("key_values") or {}
    norms = key_norms((k.get("norms") or {}).get("bands") or {})
    out, withheld, referenced, total, outside = [], [], 0, 0, 0
    for name in (kv.get("left") or kv.get("right") or {}):
        norm, off = norms.get(name), []
        for side in ("left", "right"):
            stats = (kv.get(side) or {}).get(name) or {}
            value = _finite(stats.get("mean"))
            if not math.isfinite(value):
                continue
            total += 1
            if norm is None:
                continue
            referenced += 1
            verdict = norm.verdict(value)
            if not verdict:
                continue
            z = norm.z(value)
            said = (f"{side} {value:.1f} ({'below' if verdict < 0 else 'above'}"
                    + (f", z {z:+.1f})" if math.isfinite(z) else ")"))
            why = _cycles_unheld(stats, norm, verdict)
            if why:
                withheld.append(f"Not a finding: {_outside_text(name, norm, [said])[:-1]}, but {why}.")
            else:
                outside += 1
                off.append(said)
        if off:
            out.append(_outside_text(name, norm, off))
    shown = [name for name in (kv.get("left") or kv.get("right") or {}) if no_reference(name) and norms
             and any(math.isfinite(_finite(((kv.get(s) or {}).get(name) or {}).get("mean"))) for s in ("left", "right"))]
    unvalidated = tuple(dict.fromkeys(KEY_VALUES[name][0] for name in shown))
    patient = (k.get("norms") or {}).get("no_reference") or ""
    return KeyValueFindings(tuple(out), referenced, total, outside, norms, unvalidated, patient, tuple(withheld))


def _finite(x: Any) -> float:
    return float(x) if isinstance(x, int | float) and math.isfinite(x) else math.nan
