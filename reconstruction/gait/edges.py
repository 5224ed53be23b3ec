"""Which contacts a pass's steps rest on: the pass's own, trimmed at its edges to those that fit its gait.

A pass (``bouts``) is extended at its ends by the straight walking that speeds up or slows down there
(``analysis``), and those ends border the start, the stop or a turn, where the trajectory is least sure
(feet seen by fewer cameras, sharper turns of the body than a trajectory fit follows). A contact found
there may be made up (a foot shifting while standing, a turning step) or carry an event of another stance
(a toe off long after its heel strike because the swing between two stances was not seen). Such a contact
does not make a step with a wrong value: it is left out of the pass, and the analysis notes say so.

Method: the pass's steady contacts (heel strike inside the steady part) give its typical stance time
(median of their stances) and step time (median time between consecutive heel strikes of opposite feet).
Two consecutive contacts fit (:func:`misfit`) when they are of opposite feet, their heel strikes lie within
:data:`STEP_RATIO` of the typical step time of each other, and each measured stance lies within
:data:`STANCE_RATIO` of the typical stance and ends after its heel strike. From each end of the pass's
contacts (heel strike inside the extended pass, ordered by time), the contacts before the first one that
begins two consecutive pairs that fit are left out, never beyond :data:`EDGE_STEPS` typical step times
into the steady part (the steady part's edges are blurred by the bouts' smoothing, half a window). A misfit
deeper inside is the steps check's to name (``parameters``, ``plausibility``): a contact missed there is
still reported as missed.

A toe off found after the same foot's next heel strike, or not after its own, is not of the stance its
heel strike began (:func:`own_stances`): it is made unknown, and said so, so no step rests on it.

The contacts whose toe off the cycle's support phases use (the opposite foot's contact before the cycle,
``parameters._support_phases``) are taken from the same pass: its toe off must lie inside the extended
pass, so no event of the walk before a turn is paired with one after it.

Pure computation on ``Contact`` records.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.gait.bouts import Pass
from gaitcap.reconstruction.gait.events import Contact

#: How far into the steady part a pass's edge reaches (step times): contacts there may be left out.
EDGE_STEPS = 3.0
#: A contact whose stance time lies outside this fraction of the pass's typical stance does not fit.
STANCE_RATIO = (0.6, 1.5)
#: A contact whose time to its neighbour inward lies outside this fraction of the typical step time does
#: not fit.
STEP_RATIO = (0.6, 1.5)


@dataclass(frozen=True)
class EdgeContact:
    """A contact left out of a pass at its edge: ``contact``, the pass's ``pass_index`` and ``why``."""

    contact: Contact
    pass_index: int
    why: str


@dataclass(frozen=True)
class Typical:
    """A pass's typical stance and step time (s; NaN when its steady part has too few contacts)."""

    stance_s: float
    step_s: float


def typical(contacts: Sequence[Contact], steady: Pass) -> Typical:
    """The typical stance and step time (s) of the ``contacts`` (time ordered) with a heel strike inside
    ``steady``: medians over those contacts and their consecutive opposite-foot pairs."""
    core = [c for c in contacts if steady.contains(c.heel_strike_s)]
    stances = [c.toe_off_s - c.heel_strike_s for c in core if np.isfinite(c.toe_off_s)]
    steps = [b.heel_strike_s - a.heel_strike_s for a, b in zip(core[:-1], core[1:], strict=True)
             if a.foot != b.foot]
    med = lambda x: float(np.median(x)) if len(x) >= 2 else float("nan")  # noqa: E731
    return Typical(med(stances), med(steps))


def _outside(value: float, typical_value: float, ratio: tuple[float, float]) -> bool:
    return bool(np.isfinite(typical_value) and not ratio[0] * typical_value <= value <= ratio[1] * typical_value)


def _stance_misfit(c: Contact, typ: Typical) -> str:
    stance = c.toe_off_s - c.heel_strike_s
    if not np.isfinite(stance):
        return ""  # not measured (the end of the data, or a toe off of another stance): no evidence
    if stance <= 0:
        return f"its toe off ({c.toe_off_s:.2f} s) is not after its heel strike"
    if _outside(stance, typ.stance_s, STANCE_RATIO):
        return f"a stance of {stance:.2f} s against this pass's {typ.stance_s:.2f} s"
    return ""


def misfit(edge: Contact, inward: Contact, typ: Typical) -> str:
    """Why the contact ``edge`` and its neighbour ``inward`` (towards the middle of the pass) do not fit
    the pass's gait ("" when they do; see the module docstring)."""
    if edge.foot == inward.foot:
        return f"two {edge.foot} contacts in a row"
    step = abs(inward.heel_strike_s - edge.heel_strike_s)
    if _outside(step, typ.step_s, STEP_RATIO):
        return f"{step:.2f} s from the neighbouring heel strike against this pass's step time of {typ.step_s:.2f} s"
    return _stance_misfit(edge, typ) or (f"the next contact has {why}" if (why := _stance_misfit(inward, typ)) else "")


def _trim(seq: list[Contact], depth_s: list[float], typ: Typical) -> tuple[list[Contact], list[tuple[Contact, str]]]:
    """Leave out the outermost contacts of ``seq`` (time ordered, as seen from this edge) up to the first
    that begins two consecutive pairs that fit, never one more than :data:`EDGE_STEPS` step times inside
    the steady part (``depth_s``: how far each contact's heel strike lies inside it, s)."""
    reach = EDGE_STEPS * typ.step_s if np.isfinite(typ.step_s) else 0.0
    limit = next((i for i, d in enumerate(depth_s) if d > reach), len(seq))
    why = [misfit(a, b, typ) for a, b in zip(seq[:-1], seq[1:], strict=True)]
    start = 0
    while start < min(limit, len(seq) - 2) and (why[start] or why[start + 1]):
        start += 1
    out = [(seq[k], why[k] or f"the next contacts do not fit: {why[k + 1]}") for k in range(start)]
    return seq[start:], out


def pass_contacts(wide: Pass, steady: Pass, contacts: Sequence[Contact]) -> tuple[list[Contact], list[EdgeContact], Pass]:
    """The valid ``contacts`` (time ordered, the trial's) whose heel strike is inside the extended pass
    ``wide``, less those left out at its edges (see the module docstring); those left out; and the steady
    part ``steady`` ending no farther than the contacts kept (a contact left out inside it is out of the pass)."""
    seq = [c for c in contacts if c.valid and wide.contains(c.heel_strike_s)]
    typ = typical(seq, steady)
    seq, first = _trim(seq, [c.heel_strike_s - steady.start_s for c in seq], typ)
    rev = seq[::-1]
    rev, last = _trim(rev, [steady.end_s - c.heel_strike_s for c in rev], typ)
    left = [EdgeContact(c, wide.index, why) for c, why in first + last[::-1]]
    kept = rev[::-1]
    start = max(steady.start_s, kept[0].heel_strike_s) if first and kept else steady.start_s
    end = min(steady.end_s, kept[-1].heel_strike_s) if last and kept else steady.end_s
    if end <= start:
        start, end = steady.start_s, steady.end_s
    return kept, left, dataclasses.replace(steady, start_s=start, end_s=end)


def support_contacts(wide: Pass, contacts: Sequence[Contact]) -> list[Contact]:
    """The ``contacts`` whose toe off the support phases of the pass's cycles may use: those with a toe off
    inside the extended pass ``wide`` (see the module docstring)."""
    return [c for c in contacts if c.valid and np.isfinite(c.toe_off_s) and wide.contains(c.toe_off_s)]


def edge_note(left: EdgeContact) -> str:
    """The analysis note of a contact left out at a pass's edge."""
    c = left.contact
    return (f"pass {left.pass_index}: {c.foot} contact at {c.heel_strike_s:.2f} s left out at the pass's edge "
            f"({left.why}); no step there")


def own_stances(contacts: Sequence[Contact]) -> tuple[tuple[Contact, ...], list[str]]:
    """The ``contacts`` (ordered by heel strike) with every toe off that is not of the stance its heel
    strike began made unknown (NaN), and the analysis notes saying which: a toe off not after the heel
    strike, or not before the same foot's next heel strike (it ends another stance, or the swing between
    two stances was not seen)."""
    out, notes = [], []
    for i, c in enumerate(contacts):
        nxt = next((x.heel_strike_s for x in contacts[i + 1:] if x.foot == c.foot and np.isfinite(x.heel_strike_s)),
                   float("inf"))
        if np.isfinite(c.heel_strike_s) and np.isfinite(c.toe_off_s) and not c.heel_strike_s < c.toe_off_s < nxt:
            notes.append(f"{c.foot} contact at {c.heel_strike_s:.2f} s: toe off at {c.toe_off_s:.2f} s is not of the "
                         "stance its heel strike began; its stance is not measured")
            c = dataclasses.replace(c, toe_off_s=float("nan"))
        out.append(c)
    return tuple(out), notes
