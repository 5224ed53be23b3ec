"""Benchmark: gait events on real walks (motion capture with annotated events) seen by the simulated rig.

Each installed walk (``simulator/mocap.py``: the two gaitkit walks and the three Plug-in-Gait C3D walks
of the shared data, whose Foot Strikes are force-plate confirmed) is placed in the room, sampled at 30 fps
from each of its mocap phases (150 Hz / 5; the C3D walks 120 Hz / 4), detected with the ``paper`` noise preset on the 10-camera rig,
reconstructed, and its events found by the default detector and the baselines (Zeni 2008, O'Connor 2007)
on the same trajectory. Errors are detected minus annotated (ms; frames at 30 fps: median |e|, the signed
median, the mean and the 90th percentile of |e|); an annotated event
is found when a detected event of that foot lies within 0.25 s; a detected event matching no annotation
within the annotated span of that foot (and no excluded annotation) is invented. Stance and double
support (% of the stride) come from the default detector's steps vs the annotated events. The default
detector's errors are also listed per walk and foot (every error of the 5 phases).

    python bench/gait_real.py                            # reconstruction: implicit (the default), a table
    python bench/gait_real.py --methods truth robust implicit explicit --json
    python bench/gait_real.py --criteria --methods markers truth robust implicit
    python bench/gait_real.py --walks c3d:FunctionalWalk --methods truth implicit
    python bench/gait_real.py --methods truth implicit --preset clean    # no detector noise: the fit alone
    python bench/gait_real.py --methods implicit --foot-hz 15            # the feet on a 15 Hz knot grid

``--foot-hz HZ`` gives the implicit fit's feet (ankles, heels, toes) their own knot grid at that band
limit (``BSplineBasis.fast_max_freq_hz``; the body keeps 8 Hz). ``--preset clean`` films the walks with a noise-free detector (what the fit alone does to the events;
``--seed`` draws other noise). The C3D walks' heel strikes are also scored on their plate-confirmed Foot
Strikes only (annotated within ``PLATE_MATCH_S`` of a force plate's onset, read from the C3D's analog
channels), against the annotation and against the onset itself.

``--criteria`` compares heel-strike criteria instead (``CRITERIA``): each is evaluated on the approach of
every contact the default detector finds (its rest points, the same continuous trajectory), per walk and
foot, on the inputs named by ``--methods`` (``markers``: the 150 Hz markers themselves, no rig) and on the
simulated walker (``bench/gait.py``'s 20 s paper trial, ground-truth frames, its true heel strikes; its
default, slow, Parkinsonian and hemiparetic patterns).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import sys
import time
from dataclasses import dataclass

import numpy as np

MATCH_S = 0.25
FPS = 30.0
PLATE_ONSET_N = 20.0  # force onset: vertical force this far above the unloaded plate (N; the shared data's README)
PLATE_QUIET_S = 0.05  # ... after at least this long unloaded
PLATE_MATCH_S = 0.015  # an annotated Foot Strike this close to a plate's onset is plate-confirmed


def _match(detected: np.ndarray, annotated: np.ndarray, excluded: np.ndarray,
           matched: list | None = None) -> tuple[list[float], int, int]:
    """(errors s of matched annotations, found count, invented count) for one foot and event kind; the
    matched annotations' times are appended to ``matched`` when given (in the errors' order)."""
    detected = np.sort(detected[np.isfinite(detected)])
    errors, used = [], set()
    for t in annotated:
        free = [k for k in range(len(detected)) if k not in used]
        if not free:
            continue
        k = min(free, key=lambda i: abs(detected[i] - t))
        if abs(detected[k] - t) <= MATCH_S:
            used.add(k)
            errors.append(float(detected[k] - t))
            if matched is not None:
                matched.append(float(t))
    invented = 0
    if len(annotated):
        lo, hi = annotated.min() - MATCH_S, annotated.max() + MATCH_S
        for k, t in enumerate(detected):
            if k in used or not lo <= t <= hi:
                continue
            if len(excluded) and np.min(np.abs(excluded - t)) <= MATCH_S:
                continue
            invented += 1
    return errors, len(errors), invented


def _score(events, walk, onsets_s: np.ndarray = np.zeros(0)) -> dict:
    """Errors, found, annotated and invented events of each kind, and by foot; ``plates``: the heel-strike
    errors (s) of the annotated strikes within ``PLATE_MATCH_S`` of a force plate's onset (``onsets_s``),
    and ``vs_onset``: the same detections minus those onsets."""
    out = {}
    for kind in ("heel_strike", "toe_off"):
        errors, found, invented, annotated, by_foot, plates, vs_onset = [], 0, 0, 0, {}, [], []
        for side in ("left", "right"):
            truth = getattr(walk, f"{kind}_s")[side]
            excl = np.array([t for k, s, t, _ in walk.excluded if k == kind and s == side])
            matched: list[float] = []
            e, f, i = _match(np.asarray(events[kind][side], dtype=float), truth, excl, matched)
            errors += e
            by_foot[side] = e
            found, invented, annotated = found + f, invented + i, annotated + len(truth)
            for err, t in zip(e, matched, strict=True):
                if kind == "heel_strike" and len(onsets_s) and np.min(np.abs(onsets_s - t)) <= PLATE_MATCH_S:
                    plates.append(err)
                    vs_onset.append(err + t - float(onsets_s[np.argmin(np.abs(onsets_s - t))]))
        out[kind] = {"errors_s": errors, "found": found, "annotated": annotated, "invented": invented,
                     "by_foot": by_foot, "plates": plates, "vs_onset": vs_onset}
    return out


def plate_onsets_s(path) -> np.ndarray:
    """Force onsets (s, on the C3D file's clock from its first frame) of every loading of its force plates:
    where a plate's vertical force first rises ``PLATE_ONSET_N`` above its unloaded level (the median of the
    record: one pass over the plates loads each of them briefly) after ``PLATE_QUIET_S`` below it. Type-2
    plates (the Fz channel of FORCE_PLATFORM:CHANNEL, in newtons once ezc3d has scaled it); empty
    without plates."""
    import ezc3d

    c = ezc3d.c3d(str(path))
    params = c["parameters"]
    plates = params.get("FORCE_PLATFORM", {})
    if not plates or "CHANNEL" not in plates:
        return np.zeros(0)
    rate = float(np.ravel(params["ANALOG"]["RATE"]["value"])[0])
    analogs = np.asarray(c["data"]["analogs"])[0]  # (channels, samples)
    types = np.ravel(plates.get("TYPE", {}).get("value", []))
    channels = np.asarray(plates["CHANNEL"]["value"]).reshape(-1, len(types)).T if len(types) else []
    quiet = int(round(PLATE_QUIET_S * rate))
    out = []
    for kind, chans in zip(types, channels, strict=True):
        if int(kind) != 2:
            continue
        fz = analogs[int(chans[2]) - 1]
        loaded = np.abs(fz - np.median(fz)) > PLATE_ONSET_N
        rises = np.flatnonzero(loaded[1:] & ~loaded[:-1]) + 1
        out += [k / rate for k in rises if k >= quiet and not loaded[k - quiet:k].any()]
    return np.sort(np.array(out))


def _default_events(report) -> dict:
    return {kind: {side: np.array([getattr(c, f"{kind}_s") for c in report.contacts if c.foot == side])
                   for side in ("left", "right")} for kind in ("heel_strike", "toe_off")}


def _temporal_errors(report, walk) -> dict:
    """Stance % and double support % of each step with all its events annotated, vs the annotations."""
    from gaitcap.reconstruction.gait.parameters import cycle_timing

    errors = {"stance_pct": [], "double_support_pct": []}
    for s in report.steps:
        truth = cycle_timing(s.foot, s.heel_strike_s, walk.heel_strike_s, walk.toe_off_s, match_s=MATCH_S)
        for name in errors:
            if truth is not None and np.isfinite(truth[name]) and np.isfinite(getattr(s, name)):
                errors[name].append(float(getattr(s, name) - truth[name]))
    return errors


def method_config(method: str, foot_hz: float | None = None):
    """The reconstruction config of ``method`` (METHODS name); ``foot_hz``: the implicit fit's feet on a knot
    grid of their own at that band limit (Hz)."""
    from _common import implicit_method
    from gaitcap.reconstruction.methods import METHODS

    return implicit_method(foot_hz) if method == "implicit" else METHODS[method]()


def _trajectory(walk, *, method: str, phase: int, seed: int, preset: str = "paper", foot_hz: float | None = None):
    """(times_s, points_mm, joint names, continuous sample or None, reconstruction s) of one walk seen at
    30 fps from ``phase`` with the detector noise ``preset`` and reconstructed by ``method`` (``truth``: the
    sampled markers; ``markers``: every marker frame, no rig; ``foot_hz``: see :func:`method_config`)."""
    from gaitcap.reconstruction.methods import reconstruct
    from gaitcap.simulator.mocap import SKELETON, halpe26_points, rig_view

    if method == "markers":
        return walk.times_s, halpe26_points(walk), SKELETON.joint_names, None, 0.0
    view = rig_view(walk, phase=phase, seed=seed, preset=preset)
    names = view.detections.skeleton.joint_names
    t0 = time.perf_counter()
    if method == "truth":
        points, sample = view.points_mm, None
    else:
        rec = reconstruct(view.detections, view.rig, method=method_config(method, foot_hz))
        points, sample = rec.points_mm, rec.trajectory
    return view.times_s, points, names, sample, time.perf_counter() - t0


def run_walk(walk, *, method: str, phase: int, seed: int, onsets_s: np.ndarray = np.zeros(0),
             preset: str = "paper", foot_hz: float | None = None) -> dict:
    from gaitcap.reconstruction.gait import analyze_gait
    from gaitcap.reconstruction.gait.baselines import BASELINES
    from gaitcap.reconstruction.gait.tracks import FootTracks

    times, points, names, sample, seconds = _trajectory(walk, method=method, phase=phase, seed=seed, preset=preset,
                                                        foot_hz=foot_hz)
    report = analyze_gait(points, times, names, sample=sample)
    tracks = FootTracks.from_points(points, times, names, sample=sample)
    scores = {"gaitcap": _score(_default_events(report), walk, onsets_s)}
    for name, fn in BASELINES.items():
        scores[name] = _score(fn(tracks), walk)
    return {"scores": scores, "temporal": _temporal_errors(report, walk), "seconds_reconstruction": seconds,
            "steps": len(report.steps), "edge_steps": sum(not s.steady for s in report.steps)}


def _summary(errors: list[float], scale: float = 1000.0) -> dict:
    """n, median |e|, signed median, mean (bias) and 90th percentile |e| of errors x scale (s -> ms by
    default)."""
    e = np.asarray(errors) * scale
    if len(e) == 0:
        return {"n": 0, "median_abs": None, "median": None, "bias": None, "p90_abs": None}
    return {"n": int(len(e)), "median_abs": float(np.median(np.abs(e))), "median": float(np.median(e)),
            "bias": float(np.mean(e)), "p90_abs": float(np.percentile(np.abs(e), 90))}


def _row(method: str, walk: str, detector: str, kind: str, pooled: dict) -> dict:
    summary = {f"{k}_ms" if k != "n" else k: v for k, v in _summary(pooled["errors_s"]).items()}
    return {"reconstruction": method, "walk": walk, "detector": detector, "event": kind, **summary,
            "found": pooled["found"], "annotated": pooled["annotated"], "invented": pooled["invented"]}


def _walk_names() -> list[str]:
    """The installed gaitkit walks and the shared data's Plug-in-Gait walks (``c3d:NAME``)."""
    from gaitcap.simulator.mocap import available_walks
    from gaitcap.simulator.pig_walks import available_pig_walks

    return available_walks() + [f"c3d:{name}" for name in available_pig_walks()]


def _plate_onsets(name: str) -> np.ndarray:
    """The force plates' onsets of a ``c3d:`` walk (s, the walk's clock); empty for the others."""
    from gaitcap.simulator.pig_walks import C3D_DIR

    return plate_onsets_s(C3D_DIR / f"{name[4:]}.c3d") if name.startswith("c3d:") else np.zeros(0)


def _load_walk(name: str):
    from gaitcap.simulator.mocap import load_walk
    from gaitcap.simulator.pig_walks import C3D_DIR, load_pig_walk

    return load_pig_walk(C3D_DIR / f"{name[4:]}.c3d").walk if name.startswith("c3d:") else load_walk(name)


def run(*, methods: list[str], phases: int, seed: int, walk_filter: list[str] | None = None,
        preset: str = "paper", foot_hz: float | None = None) -> dict:
    from gaitcap.simulator.mocap import rig_phases

    walks = [w for w in _walk_names() if walk_filter is None or w in walk_filter]
    if not walks:
        raise SystemExit("no real walks installed: run deploy/bootstrap.sh (install_gait_mocap)")
    rows, temporal, info, feet, plates = [], {}, {}, [], []
    for method in methods:
        everything: dict = {}
        for name in walks:
            walk = _load_walk(name)
            onsets = _plate_onsets(name)
            info[name] = {"source": walk.source, "seconds": walk.duration_s,
                          "excluded_annotations": [list(e) for e in walk.excluded],
                          "plate_onsets_s": [round(float(t), 4) for t in onsets]}
            on_plates: dict = {"plates": [], "vs_onset": []}
            pooled: dict = {}
            foot_errors: dict = {}
            temp = {"stance_pct": [], "double_support_pct": []}
            for phase in range(min(phases, rig_phases(walk, FPS))):
                try:
                    r = run_walk(walk, method=method, phase=phase, seed=seed + phase, onsets_s=onsets, preset=preset,
                                 foot_hz=foot_hz)
                except ValueError as exc:  # e.g. "no steps found": the phase counts as failed, the rest goes on
                    info[name].setdefault("failed_phases", []).append(
                        {"reconstruction": method, "phase": phase, "error": str(exc)})
                    continue
                for key in on_plates:
                    on_plates[key] += r["scores"]["gaitcap"]["heel_strike"][key]
                for det, sc in r["scores"].items():
                    for kind, s in sc.items():
                        p = pooled.setdefault((det, kind), {"errors_s": [], "found": 0, "annotated": 0,
                                                            "invented": 0})
                        for key in ("found", "annotated", "invented"):
                            p[key] += s[key]
                        p["errors_s"] += s["errors_s"]
                        if det == "gaitcap":
                            for side, e in s["by_foot"].items():
                                foot_errors.setdefault((kind, side), []).extend(e)
                for k in temp:
                    temp[k] += r["temporal"][k]
            for (kind, side), e in foot_errors.items():
                feet.append({"reconstruction": method, "walk": name, "event": kind, "foot": side,
                             **{f"{k}_ms" if k != "n" else k: v for k, v in _summary(e).items()},
                             "errors_ms": [round(1000.0 * x, 1) for x in e]})
            for (det, kind), p in pooled.items():
                rows.append(_row(method, name, det, kind, p))
                total = everything.setdefault((det, kind), {"errors_s": [], "found": 0, "annotated": 0,
                                                            "invented": 0})
                for key, value in p.items():
                    total[key] += value
            temporal[f"{method}/{name}"] = {k: _summary(vals, scale=1.0) for k, vals in temp.items()}
            if len(onsets):
                plates.append({"reconstruction": method, "walk": name, **{
                    key: {f"{k}_ms" if k != "n" else k: v for k, v in _summary(e).items()}
                    for key, e in (("vs_annotation", on_plates["plates"]), ("vs_onset", on_plates["vs_onset"]))}})
        rows += [_row(method, "all", det, kind, p) for (det, kind), p in everything.items()]
    return {"fps": FPS, "phases": phases, "seed": seed, "preset": preset, "foot_hz": foot_hz, "rows": rows,
            "by_foot": feet,
            "temporal_pct": temporal, "plates": plates, "walks": info}


# Heel-strike criteria compared on the same contacts (``--criteria``).
APPROACH_BEFORE_S = 0.25  # each contact's approach: from this long before the default heel strike ...
APPROACH_AFTER_S = 0.3  # ... to this long after it, or to the foot arriving
ARRIVED_MM = 5.0  # the foot has arrived once heel or toe is this close to its rest point
GRID_S = 0.001


@dataclass(frozen=True, eq=False)
class Approach:
    """One contact's approach on a ``GRID_S`` grid: times (N,) s; heel and toe (N, 3) mm and where they
    rest in the contact (3,) mm; the trial's walking speed (mm/s); the default detector's heel strike (s);
    ``arrived``: the grid index where heel or toe first comes within ``ARRIVED_MM`` of its rest point (the
    criteria look no later)."""

    times_s: np.ndarray
    heel_mm: np.ndarray
    toe_mm: np.ndarray
    heel_rest_mm: np.ndarray
    toe_rest_mm: np.ndarray
    walking_speed_mm_s: float
    default_s: float
    arrived: int

    @property
    def distance_mm(self) -> np.ndarray:
        """(N,) distance of the nearer of heel and toe from its rest point (mm)."""
        return np.minimum(np.linalg.norm(self.heel_mm - self.heel_rest_mm, axis=1),
                          np.linalg.norm(self.toe_mm - self.toe_rest_mm, axis=1))


def _last_fall(a: Approach, values: np.ndarray, level: float) -> float:
    """Time (s) where ``values`` last falls below ``level`` before the foot arrives (interpolated); NaN
    when it is below over the whole approach."""
    above = np.flatnonzero(values[: a.arrived + 1] >= level)
    if len(above) == 0:
        return float("nan")
    j = above[-1]
    if j + 1 >= len(values):
        return float(a.times_s[j])
    f0, f1 = values[j] - level, values[j + 1] - level
    return float(a.times_s[j] + (f0 / (f0 - f1) if f0 != f1 else 0.0) * GRID_S)


def _distance(level_mm: float):
    return lambda a: _last_fall(a, a.distance_mm, level_mm)


def _heel_speed_half(a: Approach) -> float:
    """The heel's horizontal speed falls below half the walking speed (a foot-velocity criterion)."""
    speed = np.linalg.norm(np.gradient(a.heel_mm[:, :2], a.times_s, axis=0), axis=1)
    return _last_fall(a, speed, 0.5 * a.walking_speed_mm_s)


def _heel_impact(a: Approach) -> float:
    """The peak of the heel's vertical acceleration from 0.1 s before the default to the foot's arrival
    (Hreljac & Marshall 2000)."""
    vz = np.gradient(a.heel_mm[:, 2], a.times_s)
    az = np.gradient(vz, a.times_s)
    lo = int(np.searchsorted(a.times_s, a.default_s - 0.1))
    return float(a.times_s[lo + int(np.argmax(az[lo:a.arrived + 1]))]) if a.arrived > lo else float("nan")


def _time_to_rest(a: Approach) -> float:
    """The foot, at its current speed towards its rest point, would reach it within 35 ms (the first such
    time within 80 mm of it)."""
    d = a.distance_mm
    closing = np.maximum(-np.gradient(d, a.times_s), 0.0)
    inside = np.flatnonzero((d - 0.035 * closing <= 0) & (d < 80.0))
    inside = inside[inside <= a.arrived]
    return _last_fall(dataclasses.replace(a, arrived=int(inside[0])), d - 0.035 * closing, 0.0) \
        if len(inside) else float("nan")


def _heel_rocker(a: Approach) -> float:
    """The heel within the distance it still rolls on the heel rocker: 80 mm x the foot's pitch above its
    stance pitch (rad) + 10 mm."""
    foot = a.toe_mm - a.heel_mm
    pitch = np.arctan2(foot[:, 2], np.linalg.norm(foot[:, :2], axis=1))
    rest = a.toe_rest_mm - a.heel_rest_mm
    stance = np.arctan2(rest[2], np.linalg.norm(rest[:2]))
    heel = np.linalg.norm(a.heel_mm - a.heel_rest_mm, axis=1)
    return _last_fall(a, heel - (80.0 * (pitch - stance) + 10.0), 0.0)


def _heel_lowest(a: Approach) -> float:
    """The heel at its lowest within 0.15 s of the default (a loaded heel stops descending)."""
    lo, hi = (int(np.searchsorted(a.times_s, a.default_s + d)) for d in (-0.15, 0.15))
    if hi - lo < 3:
        return float("nan")
    k = lo + int(np.argmin(a.heel_mm[lo:hi, 2]))
    return float(a.times_s[k]) if lo < k < hi - 1 else float("nan")


CRITERIA = {
    "default detector": lambda a: a.default_s,
    "heel lowest": _heel_lowest,
    "distance 30 mm": _distance(30.0),
    "distance 20 mm": _distance(20.0),
    "heel speed < speed/2": _heel_speed_half,
    "heel impact (az peak)": _heel_impact,
    "time to rest 35 ms": _time_to_rest,
    "heel rocker (pitch)": _heel_rocker,
}


def _approaches(times, points, names, sample) -> tuple[dict, list]:
    """The default detector's contacts of one trajectory as (foot, default heel strike s, Approach)."""
    from gaitcap.reconstruction.gait import analyze_gait
    from gaitcap.reconstruction.gait.analysis import walking_speed_mm_s
    from gaitcap.reconstruction.gait.bouts import find_bouts
    from gaitcap.reconstruction.gait.tracks import HEEL, TOE, FootTracks

    report = analyze_gait(points, times, names, sample=sample)
    tracks = FootTracks.from_points(points, times, names, sample=sample)
    speed = walking_speed_mm_s(find_bouts(tracks))
    out = []
    for c in report.contacts:
        if not np.isfinite(c.heel_strike_s):
            continue
        grid = np.arange(max(times[0], c.heel_strike_s - APPROACH_BEFORE_S),
                         min(times[-1], c.heel_strike_s + APPROACH_AFTER_S), GRID_S)
        pts = tracks.sampler(grid)
        a = Approach(grid, pts[:, HEEL[c.foot]], pts[:, TOE[c.foot]], np.asarray(c.heel_mm),
                     np.asarray(c.toe_mm), speed, c.heel_strike_s, len(grid) - 1)
        near = np.flatnonzero(a.distance_mm < ARRIVED_MM)
        out.append((c.foot, c.heel_strike_s, dataclasses.replace(a, arrived=int(near[0])) if len(near) else a))
    return out


def _criteria_errors(approaches, truth: dict, into: dict, walk: str) -> None:
    """Add each criterion's (error ms, fell back) at every true heel strike matched (within ``MATCH_S``) by a
    default contact of that foot to ``into[(criterion, walk, foot)]``: detected minus true; where the
    criterion finds no time in the approach (e.g. a contact at the recording's start) the default's time
    stands in, as the detector's own fallbacks do."""
    for side in ("left", "right"):
        mine = [(t, a) for foot, t, a in approaches if foot == side]
        for t_true in truth[side]:
            if not mine:
                continue
            t, a = min(mine, key=lambda m: abs(m[0] - t_true))
            if abs(t - t_true) > MATCH_S:
                continue
            for name, criterion in CRITERIA.items():
                found = criterion(a)
                into.setdefault((name, walk, side), []).append(
                    (1000.0 * ((found if np.isfinite(found) else t) - t_true), not np.isfinite(found)))


def run_criteria(*, methods: list[str], phases: int, seed: int, walk_filter: list[str] | None = None,
                 preset: str = "paper", foot_hz: float | None = None) -> dict:
    """Errors of every heel-strike criterion (``CRITERIA``) per input, walk and foot (see the module
    docstring); the walker's patterns (simulated, ground-truth frames) as input ``walker``."""
    from gaitcap.simulator import make_trial
    from gaitcap.simulator.mocap import rig_phases
    from gaitcap.simulator.params import WalkParams

    # the walker's patterns: its default (30 mm heel roll), and the slow, Parkinsonian (flat contacts,
    # 15 mm roll) and hemiparetic (paretic foot toe first) gaits of WalkParams
    WALKERS = {"default": WalkParams, "slow": WalkParams.slow, "parkinsonian": WalkParams.parkinsonian,
               "hemiparetic": WalkParams.hemiparetic}
    walks = {name: _load_walk(name) for name in _walk_names() if walk_filter is None or name in walk_filter}
    if not walks:
        raise SystemExit("no real walks installed: run deploy/bootstrap.sh (install_gait_mocap)")
    errors: dict = {}
    for method in methods:
        into = errors.setdefault(method, {})
        for name, walk in walks.items():
            for phase in range(1 if method == "markers" else min(phases, rig_phases(walk, FPS))):
                times, points, names, sample, _ = _trajectory(walk, method=method, phase=phase, seed=seed + phase,
                                                              preset=preset, foot_hz=foot_hz)
                _criteria_errors(_approaches(times, points, names, sample), walk.heel_strike_s, into, name)
    for name, params in WALKERS.items():
        trial = make_trial("paper", seconds=20.0, seed=seed, walk=params())
        _criteria_errors(_approaches(trial.times_s, trial.points_mm, trial.skeleton.joint_names, None),
                         trial.truth.heel_strike_s, errors.setdefault("walker", {}), name)
    rows = []
    for method, into in errors.items():
        for criterion in CRITERIA:
            groups: dict = {"all": []}
            for (c, walk, foot), e in into.items():
                if c == criterion:
                    for key in ("all", walk, f"{walk}/{foot}"):
                        groups.setdefault(key, []).extend(e)
            cells = {}
            for key, e in groups.items():
                cells[key] = {**_summary([x for x, _ in e], scale=1.0), "fallbacks": sum(f for _, f in e)}
            rows.append({"input": method, "criterion": criterion, "groups": cells})
    return {"fps": FPS, "phases": phases, "seed": seed, "rows": rows}


def _criteria_table(r: dict) -> str:
    lines = ["heel-strike criteria on the default detector's contacts, detected minus annotated (ms): signed "
             "median / median |e|, n (of which the default's time stood in);",
             f"30 fps inputs over {r['phases']} sampling phases, markers once at their own rate; per walk, "
             "then per walk and foot (L, R)"]
    for row in r["rows"]:
        cells = []
        for key, g in row["groups"].items():
            label = key.replace("/left", " L").replace("/right", " R")
            cells.append(f"{label} {_f(g['median']):>4}/{_f(g['median_abs']):<3}"
                         + (f" n {g['n']} ({g['fallbacks']})" if "/" not in key else ""))
        lines.append(f"{row['input']:<9}{row['criterion']:<24}" + "  ".join(cells))
    return "\n".join(lines)


def _f(x, d=0, sign=False) -> str:
    return "-" if x is None else f"{x:{'+' if sign else ''}.{d}f}"


def _frames(ms: float | None) -> float | None:
    return None if ms is None else ms * FPS / 1000.0


def _table(r: dict) -> str:
    ms_frame = 1000.0 / FPS
    lines = [f"gait events on real walks: 30 fps rig, {r['preset']} noise, seed {r['seed']}, {r['phases']} sampling "
             "phases each" + (f", the implicit fit's feet at {r['foot_hz']:g} Hz" if r.get("foot_hz") else ""),
             f"{'recon':<9}{'walk':<10}{'detector':<9}{'event':<12}{'n':>4}{'med|e| ms':>10}{'(fr)':>6}"
             f"{'median ms':>10}{'(fr)':>6}{'mean ms':>8}{'p90 ms':>8}{'(fr)':>6}{'found':>9}{'invented':>9}"]
    for row in r["rows"]:
        med, signed, p90 = row["median_abs_ms"], row["median_ms"], row["p90_abs_ms"]
        lines.append(
            f"{row['reconstruction']:<9}{row['walk']:<10}{row['detector']:<9}{row['event']:<12}{row['n']:>4}"
            f"{_f(med):>10}{_f(med and med / ms_frame, 2):>6}{_f(signed):>10}"
            f"{_f(signed if signed is None else signed / ms_frame, 2):>6}{_f(row['bias_ms']):>8}{_f(p90):>8}"
            f"{_f(p90 and p90 / ms_frame, 2):>6}{row['found']:>5}/{row['annotated']:<3}{row['invented']:>9}")
    lines.append("default detector per walk and foot (detected minus annotated, ms): n, signed median, median |e|, "
                 "each error")
    for f in r["by_foot"]:
        lines.append(f"  {f['reconstruction']:<9}{f['walk']:<10}{f['event']:<12}{f['foot']:<6}{f['n']:>3}"
                     f"{_f(f['median_ms']):>6}{_f(f['median_abs_ms']):>6}   "
                     + " ".join(f"{e:+.0f}" for e in f["errors_ms"]))
    if r["plates"]:
        lines.append(f"default detector's heel strikes at the plate-confirmed Foot Strikes (within {1000 * PLATE_MATCH_S:.0f} ms "
                     f"of a plate's {PLATE_ONSET_N:.0f} N onset): n, signed median / median |e| ms (frames), vs the "
                     "annotation; vs the onset")
    for p in r["plates"]:
        a, o = p["vs_annotation"], p["vs_onset"]
        lines.append(f"  {p['reconstruction']:<9}{p['walk']:<30}{a['n']:>3}  " + ";  ".join(
            f"{_f(x['median_ms'], sign=True):>4} / {_f(x['median_abs_ms']):<3}({_f(_frames(x['median_ms']), 2, True)} / "
            f"{_f(_frames(x['median_abs_ms']), 2)})" for x in (a, o)))
    lines.append("temporal parameters of the default detector vs the annotations (percentage points of the stride)")
    for key, t in r["temporal_pct"].items():
        for name, s in t.items():
            lines.append(f"  {key:<20}{name:<20} n {s['n']:>3}  median |e| {_f(s['median_abs'], 1)}  "
                         f"median {_f(s['median'], 1)}  bias {_f(s['bias'], 1)}  p90 {_f(s['p90_abs'], 1)}")
    for name, w in r["walks"].items():
        lines.append(f"{name}: {w['seconds']:.2f} s, {w['source']}; {len(w['excluded_annotations'])} annotation(s) "
                     "excluded by the screening")
        for f in w.get("failed_phases", []):
            lines.append(f"  {f['reconstruction']} phase {f['phase']} FAILED: {f['error']}")
    return "\n".join(lines)


def main(argv=None) -> int:
    from _common import add_foot_arg

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--methods", nargs="+", default=["implicit"],
                    choices=["truth", "dlt", "robust", "explicit", "implicit", "markers"],
                    help="markers: the 150 Hz markers without the rig (--criteria only)")
    ap.add_argument("--criteria", action="store_true", help="compare heel-strike criteria (CRITERIA)")
    ap.add_argument("--phases", type=int, default=5, choices=range(1, 6))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--walks", nargs="+", default=None,
                    help="only these walks (healthy, parkinson, c3d:FunctionalWalk, c3d:PiG_Motion3_FF, ...)")
    ap.add_argument("--preset", default="paper", help="the simulated detector's noise (simulator/noise.py: "
                    "paper, clean, ...)")
    add_foot_arg(ap)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, stream=sys.stderr)
    if "markers" in args.methods and not args.criteria:
        ap.error("--methods markers: only with --criteria")
    runner, table = (run_criteria, _criteria_table) if args.criteria else (run, _table)
    result = runner(methods=args.methods, phases=args.phases, seed=args.seed, walk_filter=args.walks,
                    preset=args.preset, foot_hz=args.foot_hz)
    if args.json:
        from _common import jsonable

        print(json.dumps(jsonable(result)))
    else:
        print(table(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
