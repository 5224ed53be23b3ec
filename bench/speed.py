"""Benchmark: wall time of the reconstruction methods (and aniposelib's in the same run).

On the synthetic 'paper' trial (10 cameras, 30 fps, default 30 s = 900 frames):
- robust triangulation and DLT for 26 joints and for 136 joints (Halpe-136 detections made by padding the
  26 body joints with offset copies): first call (with compile) and the median of repeats after;
- the implicit and explicit fits (defaults), wall time of the first call in the process (compile
  included), for 26 and 136 joints;
- the paper's implicit configuration: seconds per Adam step (26 joints, after compile);
- aniposelib's triangulate_ransac and triangulate_optim (minutes per second of trial here) on the first
  ``--clip-seconds`` of the same detections, with our robust triangulation and implicit fit timed on that
  clip too, and the ratios.

    python bench/speed.py            # the table
    python bench/speed.py --json     # one JSON object keyed by method then metric
"""

from __future__ import annotations

import argparse
import logging
import os
import statistics
import sys
import time

import numpy as np
from _common import emit

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def pad_to_halpe136(det, seed: int = 0):
    """136-joint detections: the 26 body joints, then 110 copies of random body joints moved a few px."""
    from gaitcap.reconstruction.keypoints import MultiViewKeypoints
    from gaitcap.reconstruction.skeletons import get_skeleton

    rng = np.random.default_rng(seed)
    src = rng.integers(0, 26, 110)
    extra = det.one_person[:, :, src].copy()
    extra[..., :2] += rng.normal(0, 8, (1, 1, 110, 2))
    kp = np.concatenate([det.one_person, extra], axis=2)
    return MultiViewKeypoints.of_one_person(kp, det.camera_names, det.times_s, get_skeleton("halpe136"))


def _timed(fn, repeats: int = 1) -> tuple[float, float]:
    """(first call s, median of ``repeats`` later calls s)."""
    t0 = time.perf_counter()
    fn()
    first = time.perf_counter() - t0
    later = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        later.append(time.perf_counter() - t0)
    return first, statistics.median(later) if later else float("nan")


def paper_step_seconds(det, rig, steps: int = 10) -> float:
    """Seconds per Adam step of the paper's implicit MLP on these detections (after compile)."""
    from gaitcap.reconstruction.fits.common import fill_gaps, fit_problem, reject_spikes
    from gaitcap.reconstruction.fits.implicit import ImplicitFit, _ModelObjective
    from gaitcap.reconstruction.fits.optim import _adam_chunk
    from gaitcap.reconstruction.triangulation import robust_triangulate

    fit = ImplicitFit.paper()
    tri = robust_triangulate(det, rig)
    problem = fit_problem(det, rig, tri.camera_weights)
    init = fill_gaps(reject_spikes(tri.points_mm), det.times_s, det.skeleton.joint_names)
    params, features, _ = fit.model.init(det.times_s, init, None)
    objective = _ModelObjective(fit.model, fit.loss)
    run = _adam_chunk(objective, fit.solver, steps)
    state = fit.solver.transform().init(params)
    import jax

    jax.block_until_ready(run(params, state, (problem, features), 0))
    t0 = time.perf_counter()
    jax.block_until_ready(run(params, state, (problem, features), 0))
    return (time.perf_counter() - t0) / steps


def run(*, seconds: float, cameras: int, repeats: int, anipose: bool, paper_steps: int, clip_seconds: float) -> dict:
    from gaitcap.reconstruction.methods import Explicit, Implicit, reconstruct
    from gaitcap.reconstruction.triangulation import dlt_triangulate, robust_triangulate
    from gaitcap.simulator.trial import make_trial

    trial = make_trial("paper", seconds=seconds, cameras=cameras, seed=0)
    det26, rig = trial.detections, trial.rig
    det136 = pad_to_halpe136(det26)
    out: dict[str, dict] = {}
    for j, det in ((26, det26), (136, det136)):
        first, _ = _timed(lambda d=det: reconstruct(d, rig, method=Implicit()))
        out.setdefault("implicit", {})[f"wall_s_{j}j_incl_compile"] = first
        first, _ = _timed(lambda d=det: reconstruct(d, rig, method=Explicit()))
        out.setdefault("explicit", {})[f"wall_s_{j}j_incl_compile"] = first
        first, later = _timed(lambda d=det: robust_triangulate(d, rig), repeats)
        out.setdefault("robust", {}).update({f"first_s_{j}j": first, f"s_{j}j": later})
        first, later = _timed(lambda d=det: dlt_triangulate(d, rig), repeats)
        out.setdefault("dlt", {}).update({f"first_s_{j}j": first, f"s_{j}j": later})
    if paper_steps:
        out["implicit paper"] = {"s_per_step_26j": paper_step_seconds(det26, rig, paper_steps)}
        out["implicit paper"]["hours_for_50k_steps"] = out["implicit paper"]["s_per_step_26j"] * 50_000 / 3600
    if anipose:
        from accuracy import _clip, run_anipose

        clip, _ = _clip(trial, clip_seconds)
        key = f"s_{clip_seconds:g}s_clip"
        rob_first, rob = _timed(lambda: robust_triangulate(clip, rig), repeats)
        imp, _ = _timed(lambda: reconstruct(clip, rig, method=Implicit()))
        out["robust"][key] = rob
        out["implicit"][key + "_incl_compile"] = imp
        _, dt = run_anipose(clip, rig, optim=False)
        out["anipose ransac"] = {key: dt, "ratio_to_robust": dt / rob}
        _, dt = run_anipose(clip, rig, optim=True)
        out["anipose optim"] = {key: dt, "ratio_to_implicit_incl_compile": dt / imp}
    c, t, _, _ = det26.shape
    return {"setup": {"frames": t, "cameras": c, "seconds": seconds, "cpu_count": os.cpu_count()}, **out}


def print_table(result: dict) -> None:
    s = result["setup"]
    print(f"{s['frames']} frames x {s['cameras']} cameras, {s['cpu_count']} CPUs (timings on a shared machine are noisy)")
    print(f"{'method':18s} {'metric':30s} {'value':>10s}")
    for method, row in result.items():
        if method == "setup":
            continue
        for metric, value in row.items():
            print(f"{method:18s} {metric:30s} {value:10.3f}")



def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--cameras", type=int, default=10)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--paper-steps", type=int, default=10, help="steps timed for the paper's MLP (0: skip)")
    ap.add_argument("--no-anipose", action="store_true")
    ap.add_argument("--clip-seconds", type=float, default=3.0, help="clip for the aniposelib comparison")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    result = run(seconds=args.seconds, cameras=args.cameras, repeats=args.repeats, anipose=not args.no_anipose,
                 paper_steps=args.paper_steps, clip_seconds=args.clip_seconds)
    emit(result, as_json=args.json, table=print_table)


if __name__ == "__main__":
    main()
