"""One trial against one reference: alignment, events, parameters, angles (a JSON-ready result).

Marker references (C3D, TRC) are aligned in time by the heel heights and in space by the rigid fit of
their heel, ankle and hip markers (:mod:`gaitcap.reconstruction.validation.align`); a walkway export by
the walkway alignment of :mod:`gaitcap.reconstruction.gait.walkway` (foot speed during its contacts, then a
scaled rigid 2D fit of heel and toe points). What the pair cannot compare (no events in the reference, no
angles in the trial, one side only) is listed in ``not_compared`` with the reason.
"""

from __future__ import annotations

import dataclasses
from dataclasses import asdict, dataclass

import numpy as np
from gaitcap.reconstruction.gait.analysis import compare_with_walkway
from gaitcap.reconstruction.gait.walkway import AlignmentConfig
from gaitcap.reconstruction.validation.align import (
    AlignConfig,
    AlignmentError,
    align_space,
    find_lag,
    interp_nan,
    swap_sides,
)
from gaitcap.reconstruction.validation.angles import compare_angle
from gaitcap.reconstruction.validation.events import EventMatchConfig, compare_events, event_summary
from gaitcap.reconstruction.validation.reference import FIT_JOINTS, SIDES, Reference, up_axis_of
from gaitcap.reconstruction.validation.steps import (
    PARAMETERS,
    pair_steps,
    reference_contacts,
    reference_steps,
    trial_level,
)
from gaitcap.services.validation.statistics import agreement
from gaitcap.services.validation.trial_data import TrialData

ICC_FORM = "ICC(A,1): two-way random effects, absolute agreement, single measurement (pingouin ICC2)"


@dataclass(frozen=True)
class ValidateConfig:
    align: AlignConfig = AlignConfig()
    events: EventMatchConfig = EventMatchConfig()


def _heel_heights(joints: dict[str, np.ndarray], axis: int, sign: float) -> dict[str, np.ndarray]:
    missing = [f"{s}_heel" for s in SIDES if f"{s}_heel" not in joints]
    if missing:
        raise AlignmentError(f"time: no {' or '.join(missing)} to align by")
    return {s: sign * joints[f"{s}_heel"][:, axis] for s in SIDES}


def _fit(trial: TrialData, ref_times_s: np.ndarray, joints_mm: dict, config: ValidateConfig):
    """(space, time, candidate lags) of the best-fitting candidate lag; AlignmentError (the best candidate's)
    when none fits."""
    axis, sign = up_axis_of(joints_mm)
    candidates = find_lag(trial.times_s, _heel_heights(trial.joints_mm, 2, 1.0), ref_times_s,
                          _heel_heights(joints_mm, axis, sign), config=config.align)
    names = tuple(f"{s}_{j}" for j in FIT_JOINTS for s in SIDES)
    fits, errors = [], []
    for time in candidates:  # the lag whose space fit fits best (a lag a stride off fits badly)
        try:
            fits.append((align_space(trial.times_s, trial.joints_mm, ref_times_s, joints_mm, time.lag_s,
                                     joints=names, config=config.align), time))
        except AlignmentError as exc:
            errors.append(exc)
    if not fits:
        raise errors[0]
    space, time = min(fits, key=lambda f: f[0].residual_mm)
    return space, time, candidates


def _marker_alignment(trial: TrialData, ref: Reference, config: ValidateConfig):
    try:
        space, time, candidates = _fit(trial, ref.times_s, ref.joints_mm, config)
    except AlignmentError as exc:
        try:  # a mirrored walk fits no rotation: does it fit with left and right exchanged?
            swapped, _, _ = _fit(trial, ref.times_s, swap_sides(ref.joints_mm), config)
        except AlignmentError:
            raise exc from None
        raise AlignmentError(f"space: the reference fits only with left and right exchanged (RMS residual "
                             f"{swapped.residual_mm:.0f} mm): its sides are swapped, or the trial's are") from None

    def heel_at(side, t0, t1, _i):  # median heel marker over the contact, trial frame
        t1 = t1 if np.isfinite(t1) else t0 + 0.1
        grid = np.linspace(t0, t1, 15) + time.lag_s
        p = interp_nan(grid, ref.times_s, ref.joints_mm[f"{side}_heel"])
        p = p[np.isfinite(p).all(axis=1)]
        return space.apply(np.median(p, axis=0)) if len(p) else None

    span = (max(trial.times_s[0], ref.times_s[0] - time.lag_s), min(trial.times_s[-1], ref.times_s[-1] - time.lag_s))
    alignment = {"method": "heel-height cross-correlation; rigid fit of heel, ankle and hip markers",
                 "lag_s": time.lag_s, "lag_frames": time.lag_s * trial.fps, "correlation": time.correlation,
                 "crossed_sides_correlation": time.crossed_correlation, "heel_height_residual_mm": time.residual_mm,
                 "lags_tried_s": [c.lag_s for c in candidates],
                 "overlap_s": time.overlap_s, "rotation": space.rotation.tolist(),
                 "rotation_deg": space.rotation_deg, "translation_mm": space.translation_mm.tolist(),
                 "residual_mm": space.residual_mm, "joint_residual_mm": space.joint_residual_mm,
                 "points_fitted": space.points, "outlier_fraction": space.outlier_fraction, "markers": {j: ref.labels[j] for j in space.joints}}
    return time.lag_s, span, heel_at, alignment


WALKWAY_WINDOW_S = 0.3  # the walkway alignment's search around each candidate lag (s)
WALKWAY_MAX_RESIDUAL_MM = 60.0
WALKWAY_TIMING_NOTE = ("no shared clock: the lag is where the feet are slowest during the walkway's contacts, "
                       "which on a real walk put them 40 ms early; event timing errors carry that bias")
WALKWAY_REFINE_S = 0.005  # the lag refined in 5 ms steps (a third of a 120 Hz frame of the references)


def _walkway_at(trial: TrialData, w, centre_s: float):
    """The walkway alignment searched within +-WALKWAY_WINDOW_S of ``centre_s`` (walkway time = trial time
    + lag): (lag s, comparison), or None when no offset there puts footfalls inside the trial."""
    names = tuple(trial.joints_mm)
    points = np.stack([trial.joints_mm[n] for n in names], axis=1)
    shifted = dataclasses.replace(w, first_contact_s=w.first_contact_s - centre_s, last_contact_s=w.last_contact_s - centre_s)
    try:
        comp = compare_with_walkway([(points, trial.times_s, names)], [shifted],
                                    alignment=AlignmentConfig(coarse_range_s=WALKWAY_WINDOW_S, refine_step_s=WALKWAY_REFINE_S))
    except ValueError:
        return None
    return centre_s - float(next(iter(comp.offsets_s.values()))), comp


def _walkway_score(trial: TrialData, w, lag: float, comp) -> tuple[int, int, float]:
    """(footfalls inside the trial, walkway heel strikes with a gaitcap heel strike of that foot within
    0.1 s, -residual mm): larger is better."""
    t = w.first_contact_s - lag
    inside = int(((t >= trial.times_s[0]) & (w.last_contact_s - lag <= trial.times_s[-1])).sum())
    feet = np.array(w.feet)
    matched = sum(int(np.min(np.abs(trial.events["heel_strike"][f] - x)) <= 0.1)
                  for f, x in zip(feet, t, strict=True) if len(trial.events["heel_strike"][f]))
    return inside, matched, -comp.fit_median_mm


def _walkway_alignment(trial: TrialData, ref: Reference):
    """A walkway has no heel heights: its contacts are aligned by foot speed and a scaled rigid 2D fit
    (``gaitcap.reconstruction.gait.walkway``). One straight pass fits as well a stride later (the free
    transform slides along the walkway), so every start of the walkway's contacts on gaitcap's heel
    strikes of the same foot is a candidate, and the candidate with the most footfalls inside the trial,
    then the most heel strikes matched, then the smallest residual wins; a tie is refused as ambiguous."""
    w = ref.walkway
    feet = np.array(w.feet)
    raw = sorted(float(x - h) for f, x in zip(feet, w.first_contact_s, strict=True) for h in trial.events["heel_strike"][f])
    centres = [c for k, c in enumerate(raw) if k == 0 or c - raw[k - 1] > WALKWAY_WINDOW_S / 2]  # one per lag
    found = [r for c in centres if (r := _walkway_at(trial, w, c)) is not None]
    found = [(lag, comp, _walkway_score(trial, w, lag, comp)) for lag, comp in found]
    found = [f for f in found if f[1].fit_median_mm <= WALKWAY_MAX_RESIDUAL_MM]
    if not found:
        raise AlignmentError(f"space: the walkway's footprints fit gaitcap's feet at no time offset (median "
                             f"residual above {WALKWAY_MAX_RESIDUAL_MM:.0f} mm, or no contacts): not the same walk")
    found.sort(key=lambda f: f[2], reverse=True)
    lag, comp, score = found[0]
    rival = next((f for f in found[1:] if abs(f[0] - lag) > 0.2), None)
    if rival is not None and rival[2][:2] == score[:2] and -rival[2][2] < 1.5 * max(-score[2], 5.0):
        raise AlignmentError(f"time: the walkway fits at {lag:+.2f} s and at {rival[0]:+.2f} s alike ({score[0]} "
                             f"footfalls inside, residuals {-score[2]:.0f} and {-rival[2][2]:.0f} mm): one pass "
                             f"cannot tell them apart")
    tf = comp.transform
    feet = np.array(ref.walkway.feet)

    def heel_at(side, t0, _t1, i):
        xy = tf.inverse(ref.walkway.heel_xy_mm[feet == side][i][None])[0]
        return np.array([xy[0], xy[1], 0.0])

    # only events on the walkway can be judged: from its first contact to its last heel strike (a foot off
    # the walkway lands before the last footprint lifts); the event matcher trims EventMatchConfig.edge_s
    edge = EventMatchConfig().edge_s + 0.1
    span = (max(trial.times_s[0], w.first_contact_s.min() - lag - edge),
            min(trial.times_s[-1], w.first_contact_s.max() - lag + edge))
    alignment = {"method": "walkway alignment: foot speed during contacts; scaled rigid 2D fit of heel and toe",
                 "lag_s": lag, "lag_frames": lag * trial.fps, "scale": tf.scale,
                 "rotation_deg": float(np.degrees(tf.rotation_rad)), "translation_mm": list(tf.translation_mm),
                 "residual_mm": comp.fit_median_mm, "forward_bias_mm": comp.forward_bias_mm,
                 "footfalls_inside": score[0], "heel_strikes_matched": score[1], "timing_note": WALKWAY_TIMING_NOTE}
    return lag, span, heel_at, alignment


def _sides_present(trial: TrialData) -> list[str]:
    return [s for s in SIDES if len(trial.events["heel_strike"][s])]


def validate(trial: TrialData, ref: Reference, *, config: ValidateConfig = ValidateConfig()) -> dict:
    """The JSON-ready comparison of ``trial`` with ``ref`` (:class:`AlignmentError` when they do not align)."""
    if ref.walkway is not None:
        lag, span, heel_at, alignment = _walkway_alignment(trial, ref)
    else:
        lag, span, heel_at, alignment = _marker_alignment(trial, ref, config)
    not_compared = [f"reference: {x}" for x in ref.lacks] + [f"trial: {x}" for x in trial.lacks]
    result = {"trial": trial.source, "stage": trial.stage, "reference": ref.source, "reference_kind": ref.kind,
              "fps": trial.fps, "alignment": alignment, "icc_form": ICC_FORM, "events": [], "parameters": {},
              "trial_parameters": {}, "angles": [], "step_pairs": [], "not_compared": not_compared,
              "common_span_s": list(span)}
    missing_sides = [s for s in SIDES if s not in _sides_present(trial)]
    if missing_sides:
        not_compared.append(f"trial: {' and '.join(missing_sides)} side events (gaitcap found no "
                            f"{' or '.join(missing_sides)} contacts): that side's events and steps are not compared")
    if ref.has_events and trial.steps is not None:
        ref_events = {"heel_strike": ref.heel_strike_s, "toe_off": ref.toe_off_s}
        for m in compare_events(trial.events, ref_events, lag_s=lag, span_s=span, config=config.events):
            if m.side in missing_sides:
                continue
            result["events"].append({"side": m.side, "kind": m.kind, **event_summary(m, trial.fps),
                                     "trial_s": list(m.trial_s), "reference_s": list(m.reference_s),
                                     "missed_s": list(m.missed_s), "extra_s": list(m.extra_s)})
        hs = {s: ref.heel_strike_s[s] - lag for s in SIDES}
        to = {s: ref.toe_off_s[s] - lag for s in SIDES}
        contacts = reference_contacts(hs, to, heel_at)
        pairs = pair_steps(trial.steps, reference_steps(contacts), match_s=config.events.match_s)
        result["step_pairs"] = [asdict(p) for p in pairs]
        for name in PARAMETERS:
            for side in ("all", *SIDES):
                vals = [p.values[name] for p in pairs if side == "all" or p.foot == side]
                result["parameters"].setdefault(name, {})[side] = agreement(vals)
        result["trial_parameters"] = {k: {"trial": v[0], "reference": v[1], "difference": v[0] - v[1]}
                                      for k, v in trial_level(pairs).items()}
        if not pairs:
            not_compared.append("parameters: no trial step pairs with a reference step of the same foot")
    result["angles"] = _angles(trial, ref, lag)
    return result


def _angles(trial: TrialData, ref: Reference, lag: float) -> list[dict]:
    out = []
    if not trial.angles_deg or not ref.angles_deg:
        return out
    hs = ref.heel_strike_s or {s: np.zeros(0) for s in SIDES}
    for var, sides in ref.angles_deg.items():
        for side, curve in sides.items():
            mine = trial.angles_deg.get(var, {}).get(side)
            if mine is None:
                continue
            a = compare_angle(var, side, trial.angle_times_s, mine, ref.times_s, curve, lag_s=lag,
                              heel_strikes_s=hs[side] - lag)
            if a is not None:
                out.append(asdict(a))
    return out
