"""Benchmark: gait events and parameters from a synthetic trial's reconstruction vs its ground truth,
and the walkway alignment on a synthetic walkway export.

    python bench/gait.py                              # paper preset, robust triangulation, a table
    python bench/gait.py --preset clean --method truth
    python bench/gait.py --method implicit --json     # one JSON object on stdout
    python bench/gait.py --method implicit --foot-hz 15   # the implicit fit's feet on a 15 Hz knot grid

Timings are wall-clock on whatever machine runs it (noisy on shared CPUs).
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time

import numpy as np


def _stats(x) -> dict:
    x = np.asarray([v for v in x if np.isfinite(v)], dtype=np.float64)
    if len(x) == 0:
        return {"n": 0, "mean": None, "sd": None, "max_abs": None}
    return {"n": int(len(x)), "mean": float(x.mean()), "sd": float(x.std()), "max_abs": float(np.abs(x).max())}


def _event_errors(report, truth, *, in_passes: bool) -> dict:
    out = {}
    contacts = [c for c in report.contacts
                if not in_passes or any(p.contains(c.heel_strike_s) for p in report.passes)]
    prefix = "pass_" if in_passes else ""
    for event, attr in (("heel_strike", "heel_strike_s"), ("toe_off", "toe_off_s")):
        errors = []
        for c in contacts:
            t = getattr(c, attr)
            true = getattr(truth, attr)[c.foot]
            if np.isfinite(t) and len(true):
                e = t - true[np.argmin(np.abs(true - t))]
                errors.append(e if abs(e) < 0.25 else np.nan)  # farther: a missed/extra event
        s = _stats(np.asarray(errors) * 1000.0)
        s["within_frame"] = float(np.mean(np.abs(np.asarray(errors)) < 1 / 30)) if errors else None
        out[f"{prefix}{event}_ms"] = s
    return out


def _step_errors(report, steps) -> dict:
    errs = {k: [] for k in ("step_length_mm", "stride_length_mm", "step_width_mm")}
    for s in report.steps:
        k = int(np.argmin(np.abs(steps.heel_strike_s - s.heel_strike_s)))
        if abs(steps.heel_strike_s[k] - s.heel_strike_s) > 0.25 or steps.foot[k] != s.foot:
            continue
        for name in errs:
            errs[name].append(getattr(s, name) - getattr(steps, name)[k])
    return {name: _stats(v) for name, v in errs.items()}


def run(*, preset: str, seconds: float, method: str, seed: int, config=None, foot_hz: float | None = None,
        knee_hz: float | None = None) -> dict:
    from gaitcap.reconstruction.gait import GaitConfig, TrajectoryQuality, analyze_gait, compare_with_walkway
    from gaitcap.reconstruction.methods import METHODS, reconstruct
    from gaitcap.simulator import make_trial
    from gaitcap.simulator.walkway import WalkwayExportParams, make_walkway_export

    trial = make_trial(preset, seconds=seconds, seed=seed)
    names = trial.skeleton.joint_names
    t0 = time.perf_counter()
    sample, quality = None, None
    if method == "truth":
        points = trial.points_mm
    else:
        from _common import implicit_method

        config_ = implicit_method(foot_hz, knee_hz=knee_hz) if method == "implicit" else METHODS[method]()
        rec = reconstruct(trial.detections, trial.rig, method=config_)
        points = rec.points_mm
        sample = rec.trajectory
        quality = TrajectoryQuality(rec.quality, np.full(rec.quality.shape, np.nan))
    t_rec = time.perf_counter() - t0
    config = config or GaitConfig()
    t0 = time.perf_counter()
    report = analyze_gait(points, trial.times_s, names, sample=sample, quality=quality, config=config)
    t_gait = time.perf_counter() - t0
    export = make_walkway_export(trial.truth.steps, params=WalkwayExportParams(seed=seed))
    t0 = time.perf_counter()
    cmp = compare_with_walkway([(points, trial.times_s, names)], [export.trial],
                               samples=[sample], config=config)
    t_walkway = time.perf_counter() - t0
    steps = trial.truth.steps
    return {
        "preset": preset, "seconds": seconds, "method": method, "seed": seed, "foot_hz": foot_hz, "knee_hz": knee_hz,
        "steps_found": len(report.steps), "edge_steps": sum(not s.steady for s in report.steps),
        "truth_straight_steps": int(np.sum(steps.pass_index >= 0)),
        "events": {**_event_errors(report, trial.truth, in_passes=False),
                   **_event_errors(report, trial.truth, in_passes=True)},
        "parameters": _step_errors(report, steps),
        "walkway": {
            "offset_error_s": cmp.offsets_s["0"] - export.time_offset_s,
            "scale_error": cmp.transform.scale - export.transform.scale,
            "forward_bias_mm": cmp.forward_bias_mm,
            "residuals": {k: v.__dict__ for k, v in cmp.residuals.items()},
        },
        "seconds_reconstruction": t_rec, "seconds_gait": t_gait, "seconds_walkway": t_walkway,
        "warnings": list(report.warnings),
    }


def _f(x, d=1):
    return "-" if x is None else f"{x:.{d}f}"


def _table(r: dict) -> str:
    lines = [f"gait benchmark: preset {r['preset']}, {r['seconds']} s, method {r['method']}, seed {r['seed']}",
             f"steps found {r['steps_found']}, {r['edge_steps']} of them edge steps (ground truth straight "
             f"steps {r['truth_straight_steps']})",
             f"{'quantity':<22}{'n':>5}{'mean':>9}{'SD':>9}{'max|e|':>9}{'in frame':>10}"]
    for name, s in {**r["events"], **r["parameters"]}.items():
        frame = _f(100 * s["within_frame"], 0) + "%" if s.get("within_frame") is not None else ""
        lines.append(f"{name:<22}{s['n']:>5}{_f(s['mean']):>9}{_f(s['sd']):>9}{_f(s['max_abs']):>9}{frame:>10}")
    w = r["walkway"]
    lines.append(f"walkway: offset error {w['offset_error_s'] * 1000:.0f} ms, scale error {w['scale_error']:.5f}, "
                 f"forward bias {w['forward_bias_mm']:.1f} mm (exported 13.0)")
    lines.append(f"{'residual (mm)':<22}{'n':>5}{'mean':>9}{'SD':>9}{'RMSE':>9}{'sigma_IQR':>10}")
    for name, s in w["residuals"].items():
        lines.append(f"{name:<22}{s['n']:>5}{_f(s['mean']):>9}{_f(s['sd']):>9}{_f(s['rmse']):>9}"
                     f"{_f(s['sigma_iqr']):>10}")
    lines.append(f"time: reconstruction {r['seconds_reconstruction']:.1f} s, gait {r['seconds_gait']:.2f} s, "
                 f"walkway {r['seconds_walkway']:.2f} s")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="paper", choices=["clean", "paper", "hard"])
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--method", default="robust", choices=["truth", "dlt", "robust", "explicit", "implicit"])
    ap.add_argument("--seed", type=int, default=0)
    from _common import add_foot_arg

    add_foot_arg(ap, knees=True)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, stream=sys.stderr)
    result = run(preset=args.preset, seconds=args.seconds, method=args.method, seed=args.seed, foot_hz=args.foot_hz,
                 knee_hz=args.knee_hz)
    print(json.dumps(result) if args.json else _table(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
