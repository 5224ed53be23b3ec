"""Benchmark: gait events on real walks (motion capture with annotated events) seen by the simulated rig.

Each installed walk (``simulator/mocap.py``) is placed in the room, sampled at 30 fps from
each of its 5 mocap phases (150 Hz / 5), detected with the ``paper`` noise preset on the 10-camera rig,
reconstructed, and its events found by the default detector and the baselines (Zeni 2008, O'Connor 2007)
on the same trajectory. Errors are detected minus annotated (ms; frames at 30 fps: median |e|, the signed
median, the mean and the 90th percentile of |e|); an annotated event
is found when a detected event of that foot lies within 0.25 s; a detected event matching no annotation
within the annotated span of that foot (and no excluded annotation) is invented. Stance and double
support (% of the stride) come from the default detector's steps vs the annotated events. The default
detector's errors are also listed per walk and foot (every error of the 5 phases).

    python bench/gait_real.py                            # reconstruction: implicit (the default), a table
    python bench/gait_real.py --methods truth robust implicit explicit --json
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time

import numpy as np

MATCH_S = 0.25
FPS = 30.0


def _match(detected: np.ndarray, annotated: np.ndarray, excluded: np.ndarray) -> tuple[list[float], int, int]:
    """(errors s of matched annotations, found count, invented count) for one foot and event kind."""
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


def _score(events, walk) -> dict:
    out = {}
    for kind in ("heel_strike", "toe_off"):
        errors, found, invented, annotated, by_foot = [], 0, 0, 0, {}
        for side in ("left", "right"):
            truth = getattr(walk, f"{kind}_s")[side]
            excl = np.array([t for k, s, t, _ in walk.excluded if k == kind and s == side])
            e, f, i = _match(np.asarray(events[kind][side], dtype=float), truth, excl)
            errors += e
            by_foot[side] = e
            found, invented, annotated = found + f, invented + i, annotated + len(truth)
        out[kind] = {"errors_s": errors, "found": found, "annotated": annotated, "invented": invented,
                     "by_foot": by_foot}
    return out


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


def run_walk(walk, *, method: str, phase: int, seed: int) -> dict:
    from gaitcap.reconstruction.gait import analyze_gait
    from gaitcap.reconstruction.gait.baselines import BASELINES
    from gaitcap.reconstruction.gait.tracks import FootTracks
    from gaitcap.reconstruction.methods import METHODS, reconstruct
    from gaitcap.simulator.mocap import rig_view

    view = rig_view(walk, phase=phase, seed=seed)
    names = view.detections.skeleton.joint_names
    t0 = time.perf_counter()
    if method == "truth":
        points, sample = view.points_mm, None
    else:
        rec = reconstruct(view.detections, view.rig, method=METHODS[method]())
        points, sample = rec.points_mm, rec.trajectory
    seconds = time.perf_counter() - t0
    report = analyze_gait(points, view.times_s, names, sample=sample)
    tracks = FootTracks.from_points(points, view.times_s, names, sample=sample)
    scores = {"gaitcap": _score(_default_events(report), walk)}
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


def run(*, methods: list[str], phases: int, seed: int) -> dict:
    from gaitcap.simulator.mocap import available_walks, load_walk

    walks = available_walks()
    if not walks:
        raise SystemExit("no real walks installed: run deploy/bootstrap.sh (install_gait_mocap)")
    rows, temporal, info, feet = [], {}, {}, []
    for method in methods:
        everything: dict = {}
        for name in walks:
            walk = load_walk(name)
            info[name] = {"source": walk.source, "seconds": walk.duration_s,
                          "excluded_annotations": [list(e) for e in walk.excluded]}
            pooled: dict = {}
            foot_errors: dict = {}
            temp = {"stance_pct": [], "double_support_pct": []}
            for phase in range(phases):
                r = run_walk(walk, method=method, phase=phase, seed=seed + phase)
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
        rows += [_row(method, "all", det, kind, p) for (det, kind), p in everything.items()]
    return {"fps": FPS, "phases": phases, "seed": seed, "rows": rows, "by_foot": feet, "temporal_pct": temporal,
            "walks": info}


def _f(x, d=0) -> str:
    return "-" if x is None else f"{x:.{d}f}"


def _table(r: dict) -> str:
    ms_frame = 1000.0 / FPS
    lines = [f"gait events on real walks: 30 fps rig, paper noise, {r['phases']} sampling phases each",
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
    lines.append("temporal parameters of the default detector vs the annotations (percentage points of the stride)")
    for key, t in r["temporal_pct"].items():
        for name, s in t.items():
            lines.append(f"  {key:<20}{name:<20} n {s['n']:>3}  median |e| {_f(s['median_abs'], 1)}  "
                         f"median {_f(s['median'], 1)}  bias {_f(s['bias'], 1)}  p90 {_f(s['p90_abs'], 1)}")
    for name, w in r["walks"].items():
        lines.append(f"{name}: {w['seconds']:.2f} s, {w['source']}; {len(w['excluded_annotations'])} annotation(s) "
                     "excluded by the screening")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--methods", nargs="+", default=["implicit"],
                    choices=["truth", "dlt", "robust", "explicit", "implicit"])
    ap.add_argument("--phases", type=int, default=5, choices=range(1, 6))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, stream=sys.stderr)
    result = run(methods=args.methods, phases=args.phases, seed=args.seed)
    if args.json:
        from _common import jsonable

        print(json.dumps(jsonable(result)))
    else:
        print(_table(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
