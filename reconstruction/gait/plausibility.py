"""Which steps deserve to be counted: a step enters the summary only if its events are in order and its
lengths and times are plausible for this patient.

A step is excluded, with its reason in ``Step.excluded``, when

- its events are not in walking order: the previous opposite heel strike, then this heel strike, then this
  foot's toe off; and for the gait cycle, this foot's previous heel strike before its toe off before this
  heel strike (a negative time is a detection error, never gait; ``parameters.pass_steps``);
- its step is measured from a contact that follows another contact of the same foot (two left contacts in
  a row: the contact between was missed, or one of the two is not a real contact), so the left/right
  sequence it rests on is broken (``parameters.pass_steps``);
- among the summary's steps (the steady ones, see ``parameters``), one of :data:`CHECKED` lies beyond
  :data:`MAD_LIMIT` robust standard deviations from the patient's own steps in that trial: the deviation from the median of that side's steps (the trial's
  median when the side has fewer than 3), against 1.4826 x the median absolute deviation of every such
  deviation (a standard deviation for normal data; Iglewicz & Hoaglin's modified z-score), never less
  than :data:`MIN_SPREAD` (measurement and step-to-step variation nobody would call wrong: 10 mm, and
  10 ms or the events' time precision, whichever is larger: :func:`time_precision_s`, one frame interval
  for events on the frames, half of one for events placed between frames on a continuous fit). Judged
  only with at least :data:`MIN_STEPS` steps.

Pure computation on ``Step`` records; the reason is words a clinician reads.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
from gaitcap.reconstruction.gait.parameters import Step

#: Parameters judged against the patient's own steps, with their unit ("mm" or "s").
CHECKED = {"step_length_mm": "mm", "stride_length_mm": "mm", "step_width_mm": "mm", "step_time_s": "s",
           "stride_time_s": "s", "stance_time_s": "s", "swing_time_s": "s"}
MAD_LIMIT = 3.5  # robust standard deviations
MAD_TO_SD = 1.4826  # a normal distribution's SD per median absolute deviation
MIN_SPREAD = {"mm": 10.0, "s": 0.010}  # the least robust SD: below it a difference is noise (mm, s)
MIN_STEPS = 5  # fewer steps: no median to judge against
MIN_SIDE = 3  # a side with fewer steps is judged against the trial's median
#: How finely events placed between frames on a continuous trajectory fit are timed, as a fraction of the
#: frame interval: a time between two such events varies by about this much from the measurement alone.
#: Measured on the demo's walk (``bench/gait_edges.py``: the refined stage's implicit fit, a simulated walk
#: whose steps are all alike, so every difference is measurement): the counted steps' step, stride, stance
#: and swing times scatter around the truth by 25-34 ms at 15 fps (1.4826 x their median error; 0.4-0.5 of
#: the 67 ms frame interval) and by 18-25 ms at 30 fps (0.55-0.75 of 33 ms); half a frame is the lesser.
SUB_FRAME_PRECISION = 0.5


def time_precision_s(frame_interval_s: float, resolution_s: float) -> float:
    """The events' time precision (s): the least robust SD of a step's times (:data:`MIN_SPREAD`'s
    alternative). Events on the frames (``resolution_s`` not below ``frame_interval_s``): their resolution,
    one frame; events placed between frames on a continuous fit (a finer ``resolution_s``, the search step):
    :data:`SUB_FRAME_PRECISION` of a frame interval, never less than that step. A fit places an event
    between two frames only as well as the frames around it allow, so a step whose times differ from the
    patient's others by less than a few of these is not called implausible."""
    if not (np.isfinite(frame_interval_s) and frame_interval_s > 0) or resolution_s >= frame_interval_s:
        return float(resolution_s)
    return float(max(resolution_s, SUB_FRAME_PRECISION * frame_interval_s))


def _label(name: str) -> str:
    return name.rsplit("_", 1)[0].replace("_", " ")


def _robust_sd(deviations: np.ndarray, unit: str, resolution_s: float) -> float:
    floor = MIN_SPREAD[unit] if unit == "mm" else max(MIN_SPREAD["s"], resolution_s)
    return max(MAD_TO_SD * float(np.median(np.abs(deviations))), floor)


def _deviations(steps: Sequence[Step], name: str) -> np.ndarray:
    """Each step's deviation from its side's median (NaN where the step has no value)."""
    values = np.array([getattr(s, name) for s in steps], dtype=np.float64)
    feet = np.array([s.foot for s in steps])
    out = np.full(len(steps), np.nan)
    trial = np.nanmedian(values) if np.isfinite(values).any() else np.nan
    for side in ("left", "right"):
        mine = (feet == side) & np.isfinite(values)
        centre = np.median(values[mine]) if mine.sum() >= MIN_SIDE else trial
        out[mine] = values[mine] - centre
    return out


def outliers(steps: Sequence[Step], *, resolution_s: float = 0.0) -> dict[int, str]:
    """{position in ``steps``: why} for the steps with a value beyond :data:`MAD_LIMIT` robust SDs of the
    others (see the module docstring); ``resolution_s``: the events' time precision (s,
    :func:`time_precision_s`)."""
    out: dict[int, str] = {}
    for name, unit in CHECKED.items():
        dev = _deviations(steps, name)
        ok = np.isfinite(dev)
        if ok.sum() < MIN_STEPS:
            continue
        sd = _robust_sd(dev[ok], unit, resolution_s)
        for i in np.flatnonzero(ok & (np.abs(np.nan_to_num(dev)) > MAD_LIMIT * sd)):
            value = getattr(steps[i], name)
            typical = value - dev[i]
            fmt = ".0f" if unit == "mm" else ".3f"
            why = (f"{_label(name)} {value:{fmt}} {unit} is {abs(dev[i]) / sd:.1f} robust SD from this "
                   f"patient's {typical:{fmt}} {unit} (limit {MAD_LIMIT})")
            out.setdefault(i, why)
    return out


def with_exclusions(steps: Sequence[Step], judged: Sequence[bool], reasons: dict[int, str], *,
                    resolution_s: float = 0.0) -> tuple[Step, ...]:
    """``steps`` with ``Step.excluded`` set: ``reasons`` given by position and, among the ``judged`` steps
    (the summary's set) not excluded already (events, sequence: ``parameters.pass_steps``), the
    :func:`outliers` of those. A step keeps the first reason it was given."""
    chosen = [i for i, j in enumerate(judged) if j and i not in reasons and not steps[i].excluded]
    found = outliers([steps[i] for i in chosen], resolution_s=resolution_s)
    why = {**reasons, **{chosen[k]: r for k, r in found.items()}}
    return tuple(dataclasses.replace(s, excluded=why[i]) if i in why else s for i, s in enumerate(steps))


def exclusion_note(steps: Sequence[Step]) -> str:
    """The analysis note listing the excluded steps ("" when none)."""
    out = [s for s in steps if s.excluded]
    if not out:
        return ""
    return (f"{len(out)} step(s) not counted in the summary: "
            + "; ".join(f"{s.foot} step at {s.heel_strike_s:.2f} s ({s.excluded})" for s in out))


#: Heights (mm above the floor, z = 0) a heel can have while walking: a point outside is a reconstruction
#: error (a heel keypoint rests some 40-80 mm above the floor and rises a few hundred mm in swing).
HEEL_HEIGHT_MM = (-50.0, 800.0)
#: Robust triangulation's weighted count of the views that agree on a point: below this the point rests on
#: one view's ray more than on two (the preliminary stage's -500 mm heels are such points, and heights).
MIN_AGREEING_VIEWS = 1.5


def implausible_heel_frames(heel_z_mm: np.ndarray, views: np.ndarray | None = None) -> np.ndarray:
    """(T,) bool: frames whose heel height (mm, (T,)) no walking heel has (outside :data:`HEEL_HEIGHT_MM`)
    or, with ``views`` ((T,) the weighted count of views that agree on the point, as robust triangulation
    reports it), that fewer than :data:`MIN_AGREEING_VIEWS` views agree on. NaN heights are not implausible (unknown)."""
    z = np.asarray(heel_z_mm, dtype=np.float64)
    lo, hi = HEEL_HEIGHT_MM
    out = np.isfinite(z) & ((z < lo) | (z > hi))
    if views is not None:
        out |= np.isfinite(z) & (np.asarray(views, dtype=np.float64) < MIN_AGREEING_VIEWS)
    return out
