"""Benchmark: reconstruction accuracy on a synthetic trial with known ground truth (the paper's table).

For DLT, robust triangulation and the explicit and implicit fits (gaitcap defaults) on the whole trial,
the paper's columns GC_5/10/20, L_reproj, L_skeleton, L_smooth, plus MPJPE, heel and toe errors against
the ground truth. aniposelib's ``triangulate_ransac`` and ``triangulate_optim`` (an optional bench
dependency; ``--no-anipose`` to skip) take minutes per second of trial here, so they run on the first
``--clip-seconds`` together with our robust and implicit methods on the same clip. ``--paper-steps N``
adds the paper's implicit MLP trained N steps on that clip (slow on a CPU).

    python bench/accuracy.py                 # the table (synthetic 'paper' preset, 10 cameras, 30 s)
    python bench/accuracy.py --json          # one JSON object keyed by method then metric
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import time

import numpy as np
from _common import add_foot_arg, add_trial_args, emit, implicit_method

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

COLUMNS = ("GC_5", "GC_10", "GC_20", "L_reproj", "L_skeleton", "L_smooth", "MPJPE", "heel_error", "toe_error",
           "nan_fraction", "seconds")


def anipose_group(rig):
    """Our Rig as an aniposelib CameraGroup (mm stays mm); SystemExit naming the missing package and the
    way round it when aniposelib is not installed."""
    try:
        from aniposelib.cameras import Camera as ACamera
        from aniposelib.cameras import CameraGroup
    except ImportError:
        raise SystemExit("aniposelib is not installed: pip install -e '.[bench]' for the comparison, or run "
                         "without it (bench/speed.py --no-anipose)") from None

    return CameraGroup([ACamera(matrix=c.matrix_px, dist=c.dist, size=c.size_px, rvec=c.rvec, tvec=c.tvec_mm,
                                name=c.name) for c in rig.cameras])


def anipose_points(det, gamma: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """(C, T, J, 2) px with views at or below gamma set to NaN, and the scores (C, T, J)."""
    kp = det.one_person
    conf = np.nan_to_num(kp[..., 2])
    pts = np.where((conf > gamma)[..., None], kp[..., :2], np.nan)
    return pts, conf


def run_anipose(det, rig, *, optim: bool):
    import contextlib
    import io

    group = anipose_group(rig.subset(det.camera_names))
    pts, scores = anipose_points(det)
    c, t, j, _ = pts.shape
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        if optim:
            limbs = [list(p) for p in det.skeleton.limb_indices]
            p3 = group.triangulate_optim(pts, init_ransac=True, constraints=limbs, scores=scores, verbose=False)
        else:
            p3, *_ = group.triangulate_ransac(pts.reshape(c, t * j, 2), progress=False)
    return np.asarray(p3, dtype=np.float64).reshape(t, j, 3), time.perf_counter() - t0


def _clip(trial, seconds: float):

    n = max(2, int(round(seconds * trial.fps)))
    d = trial.detections
    return d.frames(slice(None, n)), trial.points_mm[:n]


def run(*, preset: str, seconds: float, cameras: int, seed: int, anipose: bool, paper_steps: int,
        clip_seconds: float, foot_hz: float | None = None) -> dict:
    from gaitcap.reconstruction.methods import DLT, Explicit, Implicit, Robust, reconstruct
    from gaitcap.reconstruction.metrics import compute_metrics
    from gaitcap.simulator.trial import make_trial

    trial = make_trial(preset, seconds=seconds, cameras=cameras, seed=seed)
    det, rig, truth = trial.detections, trial.rig, trial.points_mm
    rows: dict[str, dict] = {"ground truth": compute_metrics(truth, det, rig, truth_mm=truth)}
    for name, method in (("dlt", DLT()), ("robust", Robust()), ("explicit", Explicit()),
                         ("implicit", implicit_method(foot_hz))):
        t0 = time.perf_counter()
        rec = reconstruct(det, rig, method=method, truth_mm=truth)
        rows[name] = dict(rec.metrics, seconds=time.perf_counter() - t0)
    if anipose or paper_steps:
        clip, clip_truth = _clip(trial, clip_seconds)
        tag = f"({clip_seconds:g} s clip)"
        ours = [("robust", Robust()), ("implicit", Implicit())]
        if paper_steps:
            ours.append((f"implicit paper {paper_steps} steps", Implicit.paper(paper_steps)))
        for name, method in ours:
            t0 = time.perf_counter()
            rec = reconstruct(clip, rig, method=method, truth_mm=clip_truth)
            rows[f"{name} {tag}"] = dict(rec.metrics, seconds=time.perf_counter() - t0)
        for name, optim in (("anipose ransac", False), ("anipose optim", True)) if anipose else ():
            pts, dt = run_anipose(clip, rig, optim=optim)
            rows[f"{name} {tag}"] = dict(compute_metrics(pts, clip, rig, truth_mm=clip_truth), seconds=dt)
    for row in rows.values():
        row.pop("camera_error_px", None)
    return {
        "setup": {"preset": preset, "seconds": seconds, "cameras": cameras, "seed": seed, "foot_hz": foot_hz,
                  "frames": int(det.shape[1]), "joints": int(det.shape[3])},
        "methods": rows,
        "targets": targets(rows),
    }


def targets(rows: dict) -> dict:
    rob, truth = rows["robust"], rows["ground truth"]
    out = {}
    for name, limit in (("implicit", 0.5), ("explicit", 0.7)):
        ratio = rows[name]["MPJPE"] / rob["MPJPE"]
        out[f"{name} MPJPE / robust <= {limit}"] = {"value": ratio, "met": bool(ratio <= limit)}
        out[f"{name} L_skeleton <= 1 mm"] = {"value": rows[name]["L_skeleton"], "met": bool(rows[name]["L_skeleton"] <= 1)}
        rel = abs(rows[name]["L_smooth"] / truth["L_smooth"] - 1)
        out[f"{name} L_smooth within 5 % of truth"] = {"value": rel, "met": bool(rel <= 0.05)}
    return out


def print_table(result: dict) -> None:
    s = result["setup"]
    print(f"synthetic '{s['preset']}' trial: {s['cameras']} cameras, {s['frames']} frames x {s['joints']} joints "
          f"(seed {s['seed']}); errors in mm, L_reproj in px (Huber), L_smooth mm/frame"
          + (f"; implicit: the feet at {s['foot_hz']:g} Hz" if s.get("foot_hz") else ""))
    width = max(len(k) for k in result["methods"]) + 2
    print("method".ljust(width) + "".join(f"{c:>12s}" for c in COLUMNS))
    for name, row in result["methods"].items():
        cells = "".join(f"{row.get(c, float('nan')):12.3f}" if c.startswith("GC") or c == "nan_fraction"
                        else f"{row.get(c, float('nan')):12.2f}" for c in COLUMNS)
        print(name.ljust(width) + cells)
    print("\ntargets:")
    for name, t in result["targets"].items():
        print(f"  {'met ' if t['met'] else 'MISS'}  {name}: {t['value']:.3f}")



def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_trial_args(ap)
    ap.add_argument("--no-anipose", action="store_true", help="skip aniposelib (optional bench dependency)")
    ap.add_argument("--paper-steps", type=int, default=0, help="also train the paper's MLP this many steps")
    ap.add_argument("--clip-seconds", type=float, default=3.0, help="clip for aniposelib and --paper-steps")
    add_foot_arg(ap)
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    result = run(preset=args.preset, seconds=args.seconds, cameras=args.cameras, seed=args.seed,
                 anipose=not args.no_anipose, paper_steps=args.paper_steps, clip_seconds=args.clip_seconds,
                 foot_hz=args.foot_hz)
    emit(result, as_json=args.json, table=print_table)


if __name__ == "__main__":
    main()
