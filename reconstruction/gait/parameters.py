"""Spatiotemporal parameters per step and per trial.

Definitions (heel positions are the stationary heel points of the contacts, see ``events``):
- step length: from the previous contralateral heel contact to this one, along the pass's direction of
  progression; stride length: from the previous ipsilateral heel contact, along progression.
- step width: perpendicular distance from this heel contact to the line through the contralateral
  foot's contacts before and after it (the walkway's "base of support").
- the gait cycle of a step runs from the previous ipsilateral heel strike to this one: stride time;
  stance = until that foot's toe off; swing = the rest; double support = initial (until the
  contralateral toe off) + terminal (from the contralateral heel strike); single support = contralateral
  swing. Percentages are of the stride time. Step time = since the previous contralateral heel strike.
- direction of progression of a pass: the common direction of two parallel lines fitted to its left and
  its right heel contacts (exact for straight walking); the body-centre direction when too few contacts.
A step is formed only when this contact and the previous contralateral contact both lie in the same
pass, a pass here including the speeding-up and slowing-down walking at its ends (steps in turns and
standing are excluded), less the contacts at its edges that do not fit its gait (``edges``); parameters that need a missing contact are NaN. The first and last step of a pass
and every step outside its steady part are edge steps (``steady`` False: acceleration/deceleration, or the
ends of a short clip): reported, but left out of the summary statistics. A step whose confidence is below
``low_confidence`` says so (``low_confidence``). A step that does not deserve to be counted (events out of
order, a broken left/right sequence, a value implausible for this patient: ``plausibility``) is reported
with the reason in ``excluded`` and left out of the summary statistics too.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from gaitcap.reconstruction.gait.bouts import Pass
from gaitcap.reconstruction.gait.events import Contact

STEP_PARAMETERS = (
    "step_length_mm", "stride_length_mm", "step_width_mm", "step_time_s", "stride_time_s",
    "stance_time_s", "swing_time_s", "single_support_s", "double_support_s", "stance_pct", "swing_pct",
    "single_support_pct", "double_support_pct",
)

#: The phases of the gait cycle: their statistics are over the steps whose cycle has every phase measured
#: (so that per side stance = single + double support and stance + swing = 100 % hold for the means too).
PHASE_PARAMETERS = ("stance_time_s", "swing_time_s", "single_support_s", "double_support_s", "stance_pct",
                    "swing_pct", "single_support_pct", "double_support_pct")


@dataclass(frozen=True)
class Step:
    """One step, ending at this foot's heel strike. Lengths mm, times s, percentages of the cycle."""

    index: int
    pass_index: int
    foot: str
    heel_strike_s: float
    toe_off_s: float
    heel_mm: tuple[float, float, float]
    toe_mm: tuple[float, float, float]
    step_length_mm: float
    stride_length_mm: float
    step_width_mm: float
    step_time_s: float
    stride_time_s: float
    stance_time_s: float
    swing_time_s: float
    single_support_s: float
    double_support_s: float
    stance_pct: float
    swing_pct: float
    single_support_pct: float
    double_support_pct: float
    confidence: float
    steady: bool = True
    low_confidence: bool = False
    excluded: str = ""  # why the step is not counted in the summary ("" when it is; see ``plausibility``)


@dataclass(frozen=True)
class LeftOut:
    """A step the analysis could not form: ``what`` is "missed contact" (two contacts of ``foot`` in a row
    in a pass: the contact between was missed or unusable) or "dropped step" (a length no walking step has,
    ``PLAUSIBLE_MM``); ``time_s``: the heel strike (s) where it happened; ``why``: plain words."""

    what: str
    foot: str
    time_s: float
    why: str


def progression_direction(feet: Sequence[str], heels_xy_mm: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """(2,) unit direction of two parallel lines through the left and the right heel contacts.

    feet: (N,) "left"/"right"; heels_xy_mm: (N, 2). Each side's points are centred on their own mean;
    the pooled scatter's main axis is the direction, oriented like ``fallback``. Falls back to
    ``fallback`` with fewer than 3 centred points.
    """
    fallback = np.asarray(fallback, dtype=np.float64)
    heels = np.asarray(heels_xy_mm, dtype=np.float64).reshape(-1, 2)
    feet = np.asarray(feet)
    centred = []
    for side in ("left", "right"):
        pts = heels[feet == side]
        if len(pts) >= 2:
            centred.append(pts - pts.mean(axis=0))
    if sum(len(c) for c in centred) < 3:
        return fallback / np.linalg.norm(fallback)
    pts = np.concatenate(centred)
    _, vecs = np.linalg.eigh(pts.T @ pts)
    d = vecs[:, -1]
    return d if d @ fallback >= 0 else -d


def _width(heel: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance (mm) of 2D point heel from the line through a and b."""
    ab = b - a
    norm = np.linalg.norm(ab)
    if norm < 1e-9:
        return float("nan")
    return float(abs(ab[0] * (heel - a)[1] - ab[1] * (heel - a)[0]) / norm)


def _nonneg(x: float) -> float:
    return x if np.isfinite(x) and x >= 0 else float("nan")


def _support_phases(p: Contact, c: Contact, c0: Contact | None) -> tuple[float, float, float]:
    """(initial double support, single support, terminal double support) s of the cycle p -> k, or NaN for
    all three unless the events follow each other as in walking: p's heel strike, then c0's toe off, c's
    heel strike, p's toe off (each phase >= 0, so stance = their sum). A contralateral toe off before p's
    heel strike (a missed or unusable contact between c0 and p, or a toe off found early) or after c's
    heel strike would make one phase negative and the single support longer than the stance around it."""
    nan = float("nan")
    if c0 is None or not c0.valid:
        return nan, nan, nan
    events = (p.heel_strike_s, c0.toe_off_s, c.heel_strike_s, p.toe_off_s)
    phases = tuple(float(b - a) for a, b in zip(events[:-1], events[1:], strict=True))
    return phases if all(np.isfinite(x) and x >= 0 for x in phases) else (nan, nan, nan)


def _timing(k: Contact, p: Contact | None, c: Contact, c0: Contact | None) -> dict[str, float]:
    nan = float("nan")
    out = dict.fromkeys(STEP_PARAMETERS[3:], nan)
    out["step_time_s"] = _nonneg(k.heel_strike_s - c.heel_strike_s)
    if p is None:
        return out
    stride = _nonneg(k.heel_strike_s - p.heel_strike_s)
    stance = _nonneg(p.toe_off_s - p.heel_strike_s)
    swing = _nonneg(k.heel_strike_s - p.toe_off_s)
    ds_init, single, ds_term = _support_phases(p, c, c0)
    out.update(stride_time_s=stride, stance_time_s=stance, swing_time_s=swing,
               single_support_s=single, double_support_s=ds_init + ds_term)
    for name in ("stance", "swing", "single_support", "double_support"):
        seconds = out[f"{name}_s" if "support" in name else f"{name}_time_s"]
        out[f"{name}_pct"] = 100.0 * seconds / stride if stride > 0 else nan
    return out


def pass_steps(pass_: Pass, contacts: Sequence[Contact], all_contacts: Sequence[Contact],
               confidence: dict[int, float], first_index: int = 0, *, steady: Pass | None = None,
               low_confidence: float = 0.0) -> tuple[list[Step], list[LeftOut]]:
    """Steps of one pass from the trial's contacts (ordered by heel strike), and the steps it could not
    form (:class:`LeftOut`, their ``why`` the analysis's notes).

    ``confidence`` maps id(contact) -> confidence in [0, 1]; a step gets the lower of its two contacts.
    ``steady``: the steady part of the pass (default: all of it); the first and last step and steps with
    a contact outside it are edge steps. Steps with confidence below ``low_confidence`` are flagged.
    """
    seq = [c for c in contacts if c.valid and pass_.contains(c.heel_strike_s)]
    direction = progression_direction([c.foot for c in seq], np.array([c.heel_mm[:2] for c in seq]),
                                      np.asarray(pass_.direction))
    core = steady or pass_
    steps, left_out = [], []
    for i in range(1, len(seq)):
        k, c = seq[i], seq[i - 1]
        after = seq[i - 2] if i >= 2 and seq[i - 2].foot == c.foot else None  # two c-foot contacts in a row
        if c.foot == k.foot:
            left_out.append(LeftOut("missed contact", k.foot, k.heel_strike_s,
                                    f"pass {pass_.index}: two {k.foot} contacts in a row at {c.heel_strike_s:.2f} s "
                                    f"and {k.heel_strike_s:.2f} s (the contact between was missed or unusable); "
                                    "no step there"))
            continue
        p = seq[i - 2] if i >= 2 and seq[i - 2].foot == k.foot else None
        n = seq[i + 1] if i + 1 < len(seq) and seq[i + 1].foot == c.foot else None
        earlier = [x for x in all_contacts if x.foot == c.foot and p is not None
                   and x.heel_strike_s < p.heel_strike_s]
        c0 = earlier[-1] if earlier else None
        heel, heel_c = np.asarray(k.heel_mm[:2]), np.asarray(c.heel_mm[:2])
        values = _timing(k, p, c, c0)
        values["step_length_mm"] = float((heel - heel_c) @ direction)
        values["stride_length_mm"] = (float((heel - np.asarray(p.heel_mm[:2])) @ direction)
                                      if p is not None else float("nan"))
        values["step_width_mm"] = _width(heel, heel_c, np.asarray(n.heel_mm[:2])) if n else float("nan")
        implausible = _implausible(values)
        if implausible:
            left_out.append(LeftOut("dropped step", k.foot, k.heel_strike_s, f"pass {pass_.index}: {k.foot} step at "
                                    f"{k.heel_strike_s:.2f} s dropped ({implausible})"))
            continue
        conf = min(confidence.get(id(k), 1.0), confidence.get(id(c), 1.0))
        edge = (i == 1 or i == len(seq) - 1 or not (core.contains(k.heel_strike_s) and core.contains(c.heel_strike_s))
                or (p is not None and not core.contains(p.heel_strike_s)))  # a cycle begun speeding up
        excluded = (f"left/right sequence broken: measured from the second of two {c.foot} contacts in a row "
                    f"({after.heel_strike_s:.2f} s and {c.heel_strike_s:.2f} s)" if after is not None
                    else _order_problem(k, p, c))
        steps.append(Step(first_index + len(steps), pass_.index, k.foot, k.heel_strike_s, k.toe_off_s,
                          k.heel_mm, k.toe_mm, confidence=conf, steady=not edge,
                          low_confidence=conf < low_confidence, excluded=excluded,
                          **{name: values[name] for name in STEP_PARAMETERS}))
    return steps, left_out


def _order_problem(k: Contact, p: Contact | None, c: Contact) -> str:
    """Why the events of the step ``c`` -> ``k`` (cycle from ``p``) are not in walking order ("" when they
    are): the opposite heel strike before this one, this heel strike before its toe off, and the cycle's
    heel strike, toe off and this heel strike in that order."""
    if not c.heel_strike_s < k.heel_strike_s:
        return (f"events out of order: the opposite heel strike ({c.heel_strike_s:.2f} s) is not before this "
                f"one ({k.heel_strike_s:.2f} s)")
    if np.isfinite(k.toe_off_s) and not k.toe_off_s > k.heel_strike_s:
        return f"events out of order: toe off ({k.toe_off_s:.2f} s) not after heel strike ({k.heel_strike_s:.2f} s)"
    if p is not None and np.isfinite(p.toe_off_s) and not p.heel_strike_s < p.toe_off_s < k.heel_strike_s:
        return (f"events out of order: this foot's toe off ({p.toe_off_s:.2f} s) is not between its heel "
                f"strikes ({p.heel_strike_s:.2f} s and {k.heel_strike_s:.2f} s)")
    return ""


def _annotated_contacts(foot: str, heel_strikes_s, toe_offs_s) -> list[Contact]:
    """Contacts of one foot from event lists: each heel strike with the first toe off before the next."""
    hs = np.sort(np.asarray(heel_strikes_s, dtype=np.float64))
    to = np.sort(np.asarray(toe_offs_s, dtype=np.float64))
    out = []
    for i, t in enumerate(hs):
        end = hs[i + 1] if i + 1 < len(hs) else np.inf
        after = to[(to > t) & (to < end)]
        out.append(Contact(foot, float(t), float(after[0]) if len(after) else float("nan"), (0.0,) * 3,
                           (0.0,) * 3, 0.0, True))
    return out


def cycle_timing(foot: str, heel_strike_s: float, heel_strikes_s: dict, toe_offs_s: dict, *,
                 match_s: float) -> dict[str, float] | None:
    """Timing parameters (the ``STEP_PARAMETERS`` from step_time_s on) of the step of ``foot`` ending at
    ``heel_strike_s``, computed from reference events (e.g. force plates): ``{"left"|"right": (K,) s}``
    heel strikes and toe offs. None when no reference heel strike of that foot lies within ``match_s``."""
    contacts = sorted(_annotated_contacts("left", heel_strikes_s["left"], toe_offs_s["left"])
                      + _annotated_contacts("right", heel_strikes_s["right"], toe_offs_s["right"]),
                      key=lambda c: c.heel_strike_s)
    mine = [i for i, c in enumerate(contacts) if c.foot == foot and abs(c.heel_strike_s - heel_strike_s) <= match_s]
    if not mine or mine[0] == 0:
        return None
    i = mine[0]
    k, c = contacts[i], contacts[i - 1]
    if c.foot == foot:
        return None
    p = contacts[i - 2] if i >= 2 and contacts[i - 2].foot == foot else None
    earlier = [x for x in contacts[:max(i - 2, 0)] if x.foot == c.foot] if p is not None else []
    return _timing(k, p, c, earlier[-1] if earlier else None)


# Plausible ranges of a walking step (mm): outside them a step is a detection error, not gait.
PLAUSIBLE_MM = {"step_length_mm": (0.0, 1500.0), "stride_length_mm": (0.0, 2500.0), "step_width_mm": (0.0, 700.0)}


def _implausible(values: dict[str, float]) -> str:
    """Why a step's lengths are implausible ("" when they are fine; NaN is fine)."""
    for name, (lo, hi) in PLAUSIBLE_MM.items():
        v = values[name]
        if np.isfinite(v) and not lo < v < hi:
            return f"{name} {v:.0f} outside {lo:.0f}-{hi:.0f}"
    return ""


@dataclass(frozen=True)
class Stats:
    """Summary statistics of one parameter: count, mean, SD (ddof=1) and CV (% of the mean)."""

    n: int
    mean: float
    sd: float
    cv_pct: float

    @classmethod
    def of(cls, values: Sequence[float]) -> Stats:
        x = np.asarray([v for v in values if np.isfinite(v)], dtype=np.float64)
        if len(x) == 0:
            return cls(0, float("nan"), float("nan"), float("nan"))
        mean = float(x.mean())
        sd = float(x.std(ddof=1)) if len(x) > 1 else float("nan")
        return cls(len(x), mean, sd, 100.0 * sd / abs(mean) if mean else float("nan"))


@dataclass(frozen=True)
class GaitSummary:
    """Per-trial summary.

    Attributes:
        num_steps, num_passes: counts of analysed steps and passes.
        cadence_steps_min: 60 / mean step time (steps/min).
        gait_speed_m_s: total stride length / total stride time (m/s).
        parameters: name -> {"all" | "left" | "right" -> Stats}.
        asymmetry_pct: name -> symmetry index (%) of Robinson, Herzog & Nigg (1987),
            SI = 100 |left mean - right mean| / (0.5 (left mean + right mean)); 0 is symmetric.
        num_edge_steps: steps reported but left out of these statistics (first/last steps of a pass,
            acceleration and deceleration; see ``Step.steady``).
        num_excluded_steps: steady steps left out because they do not deserve to be counted (see
            ``Step.excluded`` and ``plausibility``).
    Statistics ("all", "left", "right": n, mean, SD, CV) are over the steady steps that are counted.
    """

    num_steps: int
    num_passes: int
    cadence_steps_min: float
    gait_speed_m_s: float
    parameters: dict[str, dict[str, Stats]] = field(default_factory=dict)
    asymmetry_pct: dict[str, float] = field(default_factory=dict)
    num_edge_steps: int = 0
    num_excluded_steps: int = 0


def summarise(steps: Sequence[Step], num_passes: int) -> GaitSummary:
    """Per-trial and per-side statistics, cadence, gait speed and asymmetry of the steady ``steps``
    (all of them when none is steady, e.g. a clip of two steps) less those excluded (``Step.excluded``); the cycle phases (``PHASE_PARAMETERS``)
    over those of them whose phases are all measured (all of them when none is)."""
    all_steps = list(steps)
    pool = [s for s in all_steps if s.steady] or all_steps
    steps = [s for s in pool if not s.excluded]
    complete = [s for s in steps if all(np.isfinite(getattr(s, n)) for n in PHASE_PARAMETERS)] or steps
    params, asym = {}, {}
    for name in STEP_PARAMETERS:
        chosen = complete if name in PHASE_PARAMETERS else steps
        groups = {"all": chosen, "left": [s for s in chosen if s.foot == "left"],
                  "right": [s for s in chosen if s.foot == "right"]}
        params[name] = {g: Stats.of([getattr(s, name) for s in group]) for g, group in groups.items()}
        left, right = params[name]["left"].mean, params[name]["right"].mean
        mid = 0.5 * (left + right)
        asym[name] = float(100.0 * abs(left - right) / abs(mid)) if np.isfinite(mid) and mid else float("nan")
    step_time = params["step_time_s"]["all"].mean
    pairs = [(s.stride_length_mm, s.stride_time_s) for s in steps
             if np.isfinite(s.stride_length_mm) and np.isfinite(s.stride_time_s)]
    speed = sum(p[0] for p in pairs) / sum(p[1] for p in pairs) / 1000.0 if pairs else float("nan")
    cadence = 60.0 / step_time if np.isfinite(step_time) and step_time > 0 else float("nan")
    return GaitSummary(len(all_steps), num_passes, float(cadence), float(speed), params, asym,
                       len(all_steps) - len(pool), len(pool) - len(steps))
