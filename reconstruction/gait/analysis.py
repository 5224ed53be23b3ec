"""The gait analysis entry point: a 3D trajectory in, a GaitReport out."""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence

import numpy as np
from gaitcap.reconstruction.gait.bouts import Bouts, Pass, find_bouts
from gaitcap.reconstruction.gait.config import GaitConfig
from gaitcap.reconstruction.gait.edges import edge_note, own_stances, pass_contacts, support_contacts
from gaitcap.reconstruction.gait.events import Contact, detect_contacts, event_timing, rest_speed_mm_s
from gaitcap.reconstruction.gait.parameters import LeftOut, Step, pass_steps, progression_direction, summarise
from gaitcap.reconstruction.gait.plausibility import exclusion_note, time_precision_s, with_exclusions
from gaitcap.reconstruction.gait.quality import TrajectoryQuality, contact_confidence
from gaitcap.reconstruction.gait.report import GaitReport
from gaitcap.reconstruction.gait.tracks import FootTracks, foot_joint_indices
from gaitcap.reconstruction.gait.walkway import AlignmentConfig, WalkwayTrial, align_walkway

log = logging.getLogger(__name__)


def walking_speed_mm_s(bouts: Bouts, config: GaitConfig = GaitConfig()) -> float:
    """The trial's walking speed (mm/s): the median speed of its straight passes (the speed the event
    thresholds scale with). ValueError saying why when there is no pass."""
    if not bouts.passes:
        kinds = {s.kind for s in bouts.segments}
        if kinds <= {"standing", "gap"}:
            raise ValueError("standing only: the body centre never moves faster than "
                             f"{config.min_walking_speed_mm_s:.0f} mm/s, so there are no steps to analyse")
        raise ValueError(f"no straight walking pass of at least {config.min_pass_s} s (only turns or short "
                         "walking bouts), so there are no steps to analyse")
    return float(np.median([p.speed_mm_s for p in bouts.passes]))


def _confidences(contacts, tracks: FootTracks, joint_names, quality, config) -> dict[int, float]:
    feet, _ = foot_joint_indices(joint_names)
    out = {}
    for c in contacts:
        start = c.heel_strike_s if np.isfinite(c.heel_strike_s) else tracks.times_s[0]
        end = c.toe_off_s if np.isfinite(c.toe_off_s) else tracks.times_s[-1]
        a, b = np.searchsorted(tracks.times_s, [start, end])
        joints = feet[:2] if c.foot == "left" else feet[2:]
        out[id(c)] = contact_confidence(heel_spread_mm=c.heel_spread_mm, frames=slice(a, b + 1),
                                        joints=joints, quality=quality, config=config)
    return out


def _extended(bouts: Bouts, p: Pass) -> Pass:
    """The pass with the straight walking at its ends (speeding up, slowing down: "transition" segments
    that touch it), whose steps are reported as edge steps."""
    start, end = p.start_s, p.end_s
    segs = bouts.segments
    i = next(k for k, s in enumerate(segs) if s.kind == "pass" and s.start_s == p.start_s)
    if i > 0 and segs[i - 1].kind == "transition":
        start = segs[i - 1].start_s
    if i + 1 < len(segs) and segs[i + 1].kind == "transition":
        end = segs[i + 1].end_s
    return Pass(p.index, start, end, p.direction, p.speed_mm_s)


def _counted(steps: list[Step], precision_s: float) -> list[Step]:
    """The steps with the implausible ones among the summary's (the steady ones, or all when none is)
    marked excluded (see ``plausibility``; ``precision_s``: the events' time precision)."""
    judged = [s.steady for s in steps] if any(s.steady for s in steps) else [True] * len(steps)
    return list(with_exclusions(steps, judged, {}, resolution_s=precision_s))


def _steps(bouts: Bouts, contacts: Sequence[Contact], confidence,
           config: GaitConfig) -> tuple[list[Step], list[Pass], list[str], list[LeftOut]]:
    steps, passes, warnings, left_out = [], [], [], []
    for p in bouts.passes:
        wide = _extended(bouts, p)
        seq, edge, p = pass_contacts(wide, p, contacts)
        found, missed = pass_steps(wide, seq, support_contacts(wide, contacts), confidence, first_index=len(steps),
                                   steady=p, low_confidence=config.low_confidence)
        steps += found
        warnings += [edge_note(e) for e in edge] + [m.why for m in missed]
        left_out += missed
        d = progression_direction([c.foot for c in seq], np.array([c.heel_mm[:2] for c in seq]),
                                  np.asarray(p.direction))
        passes.append(Pass(p.index, p.start_s, p.end_s, (float(d[0]), float(d[1])), p.speed_mm_s))
    low = [s for s in steps if s.low_confidence]
    if low:
        warnings.append(f"{len(low)} step(s) detected with low confidence (< {config.low_confidence:.2f}): "
                        + ", ".join(f"{s.foot} at {s.heel_strike_s:.2f} s" for s in low))
    return steps, passes, warnings, left_out


def analyze_gait(
    points_mm: np.ndarray,
    times_s: np.ndarray,
    joint_names: Sequence[str],
    *,
    sample: Callable[[np.ndarray], np.ndarray] | None = None,
    quality: TrajectoryQuality | None = None,
    config: GaitConfig = GaitConfig(),
) -> GaitReport:
    """Gait events, bouts and spatiotemporal parameters of one trial.

    Args:
        points_mm: (T, J, 3) joint positions (mm, z up, floor near z = 0); NaN where unknown.
        times_s: (T,) frame times (s, strictly increasing).
        joint_names: (J,) snake_case names; needs left/right heel and big toe (or foot index).
        sample: optional continuous trajectory ``sample(times_s (N,)) -> (N, J, 3)`` mm for sub-frame
            events (e.g. an implicit fit); a cubic spline through the frames otherwise.
        quality: optional per-frame/joint number of views and reprojection error (confidence).
        config: thresholds.

    Raises:
        ValueError: too short a trial, missing joints, too many NaN, standing only, no pass or no step.
    """
    tracks = FootTracks.from_points(points_mm, times_s, joint_names, sample=sample, config=config)
    if quality is not None and quality.num_views.shape != np.shape(points_mm)[:2]:
        raise ValueError(f"quality: shape {quality.num_views.shape} does not match points_mm "
                         f"{np.shape(points_mm)[:2]}")
    bouts = find_bouts(tracks, config)
    speed = walking_speed_mm_s(bouts, config)
    contacts = detect_contacts(tracks, speed, config, noise_mm_s=tracks.rest_noise_mm_s(bouts.walking(tracks.times_s)))
    contacts, stance_notes = own_stances(contacts)
    confidence = _confidences(contacts, tracks, joint_names, quality, config)
    steps, passes, warnings, left_out = _steps(bouts, contacts, confidence, config)
    warnings = stance_notes + warnings
    timing = event_timing(tracks, config)
    steps = _counted(steps, time_precision_s(timing.frame_interval_s, timing.resolution_s))
    warnings += [note] if (note := exclusion_note(steps)) else []
    if tracks.all_gaps_s:
        warnings.append("data gaps (no contacts measured there): " + ", ".join(
            f"{a:.2f}-{b:.2f} s" for a, b in tracks.all_gaps_s))
    turns = [s for s in bouts.segments if s.kind == "turn" and s.end_s - s.start_s >= 0.5]
    if turns:
        warnings.append("turns (steps there are not analysed): " + ", ".join(
            f"{s.start_s:.2f}-{s.end_s:.2f} s" for s in turns))
    walked = [_extended(bouts, p) for p in bouts.passes]
    outside = [c for c in contacts if c.valid and not any(w.contains(c.heel_strike_s) for w in walked)]
    if outside:
        warnings.append(f"{len(outside)} contact(s) in turns, standing or at pass edges were not used "
                        "as steps")
    if not steps:
        raise ValueError(f"no steps found: {len(contacts)} foot contact(s) detected in {len(passes)} "
                         "pass(es), but no pair of consecutive left/right contacts inside one pass")
    return GaitReport(tuple(steps), summarise(steps, len(passes)), tuple(passes), bouts.segments,
                      contacts, tuple(warnings), timing=timing, left_out=tuple(left_out))


def compare_with_walkway(
    trials: Sequence[tuple[np.ndarray, np.ndarray, Sequence[str]]],
    walkway: Sequence[WalkwayTrial],
    *,
    samples: Sequence[Callable[[np.ndarray], np.ndarray] | None] | None = None,
    config: GaitConfig = GaitConfig(),
    alignment: AlignmentConfig = AlignmentConfig(),
):
    """Align a session's trials ``(points_mm, times_s, joint_names)`` with their walkway exports
    (same order) and return the ``WalkwayComparison`` (one transform, one offset per trial)."""
    samples = list(samples) if samples is not None else [None] * len(trials)
    tracks, rest = [], []
    for (points, times, names), sample in zip(trials, samples, strict=True):
        t = FootTracks.from_points(points, times, names, sample=sample, config=config)
        speed = walking_speed_mm_s(find_bouts(t, config), config)
        tracks.append(t)
        rest.append(rest_speed_mm_s(speed, config, t.rest_noise_mm_s()))
    return align_walkway(tracks, walkway, rest, alignment)
