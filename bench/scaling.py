"""Benchmark: how the reconstruction's cost grows with the length of the trial, measured as a user runs it.

For each trial length (default 30 / 120 / 360 / 600 s) it writes a synthetic trial with
``gaitcap simulate`` (10 cameras, Halpe-26, 30 fps, 'paper' noise), then runs
``gaitcap reconstruct --method M`` for each method as its own process and records that process's wall
time, CPU time (user + system) and peak resident memory (from ``wait4``), and the MPJPE of its result
against the ground truth. The per-second cost ratio is (time / trial s) / (the same at the shortest
trial): 1.0 means linear, above 1 means each second of walking costs more on the long trial. Wall time on
a shared machine is noisy; the CPU time is less so.

Targets (issue: long sessions), for the default implicit fit: the 360 s trial takes at most 12x the
30 s time and at most 1.5 GB; the 600 s trial completes in at most 2 GB.

    python bench/scaling.py                                   # the table
    python bench/scaling.py --seconds 30 120 --methods implicit
    python bench/scaling.py --json                            # one JSON object
"""

from __future__ import annotations

import argparse
import logging
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _common import emit

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

GAITCAP = [sys.executable, "-c", "from gaitcap.services.cli import main; main()"]
METHODS = ("dlt", "robust", "explicit", "implicit")
GB = 1e9


def run_process(args: list[str]) -> dict:
    """Run a command to completion: wall s, cpu s (user + system) and peak RSS bytes of that process
    (``wait4``), exit code, stdout and the end of stderr."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        t0 = time.perf_counter()
        proc = subprocess.Popen(args, stdout=out, stderr=err, text=True)
        _, status, usage = os.wait4(proc.pid, 0)  # reaped here, so the usage is this child's alone
        wall = time.perf_counter() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        stdout, stderr = out.read(), err.read()
    return {"wall_s": wall, "cpu_s": usage.ru_utime + usage.ru_stime, "peak_bytes": usage.ru_maxrss * 1024,
            "returncode": proc.returncode, "stdout": stdout, "stderr_tail": stderr[-2000:]}


def simulate(folder: Path, seconds: float, cameras: int, seed: int) -> dict:
    res = run_process([*GAITCAP, "simulate", "--out", str(folder), "--seconds", f"{seconds:g}",
                       "--cameras", str(cameras), "--seed", str(seed), "--preset", "paper"])
    if res["returncode"] != 0:
        raise RuntimeError(f"gaitcap simulate --seconds {seconds:g} failed:\n{res['stderr_tail']}")
    return res


def reconstruct(folder: Path, method: str) -> dict:
    out = folder / f"{method}.npz"
    res = run_process([*GAITCAP, "reconstruct", "--calibration", str(folder / "calibration.toml"),
                       "--keypoints", str(folder / "keypoints.npz"), "--method", method, "--out", str(out)])
    row = {k: res[k] for k in ("wall_s", "cpu_s", "peak_bytes", "returncode")}
    if res["returncode"] != 0:
        row["error"] = res["stderr_tail"].strip().splitlines()[-1:] or ["(no message)"]
        return row
    row["MPJPE"] = mpjpe_mm(out, folder / "ground_truth.npz")
    out.unlink()
    return row


def mpjpe_mm(result: Path, truth: Path) -> float:
    from gaitcap.reconstruction.metrics import ground_truth_errors
    from gaitcap.services.processing.outputs import read_npz

    traj, _ = read_npz(result)
    return ground_truth_errors(traj.points_mm, np.load(truth)["points_mm"], list(traj.joint_names))["MPJPE"]


def add_ratios(rows: dict) -> None:
    """Per-second cost ratios against the shortest trial, per method, for wall and CPU time."""
    lengths = sorted(rows, key=float)
    base = rows[lengths[0]]
    for length in lengths:
        for method, row in rows[length].items():
            ref = base.get(method, {})
            for key in ("wall_s", "cpu_s"):
                if "error" in row or "error" in ref or key not in ref:
                    continue
                row[f"{key[:-2]}_per_s_ratio"] = (row[key] / float(length)) / (ref[key] / float(lengths[0]))


def check_targets(rows: dict) -> dict:
    out = {}
    imp = {length: r.get("implicit", {}) for length, r in rows.items()}
    r30, r360, r600 = imp.get("30", {}), imp.get("360", {}), imp.get("600", {})
    if "wall_s" in r30 and "wall_s" in r360 and "error" not in r360:
        ratio = r360["wall_s"] / r30["wall_s"]
        out["implicit 360 s wall <= 12 x 30 s"] = {"value": ratio, "met": bool(ratio <= 12.0)}
    if "peak_bytes" in r360:
        gb = r360["peak_bytes"] / GB
        out["implicit 360 s peak <= 1.5 GB"] = {"value": gb, "met": bool(gb <= 1.5 and "error" not in r360)}
    if "peak_bytes" in r600:
        gb = r600["peak_bytes"] / GB
        out["implicit 600 s completes in <= 2 GB"] = {"value": gb, "met": bool(gb <= 2.0 and "error" not in r600)}
    return out


def run(*, seconds: list[float], methods: list[str], cameras: int, seed: int, workdir: Path) -> dict:
    rows: dict[str, dict] = {}
    sims: dict[str, dict] = {}
    for length in seconds:
        key = f"{length:g}"
        folder = workdir / f"trial_{key}s"
        sim = simulate(folder, length, cameras, seed)
        sims[key] = {"wall_s": sim["wall_s"], "peak_bytes": sim["peak_bytes"]}
        rows[key] = {}
        for method in methods:
            logging.info("%s s: %s", key, method)
            rows[key][method] = reconstruct(folder, method)
    add_ratios(rows)
    return {
        "setup": {"seconds": seconds, "methods": methods, "cameras": cameras, "seed": seed, "fps": 30,
                  "preset": "paper", "cpus": os.cpu_count()},
        "simulate": sims,
        "reconstruct": rows,
        "targets": check_targets(rows),
    }


def print_table(result: dict) -> None:
    s = result["setup"]
    print(f"scaling: synthetic 'paper' trials, {s['cameras']} cameras, 30 fps, Halpe-26, {s['cpus']} CPUs; "
          "each method is one `gaitcap reconstruct` process")
    print(f"{'trial s':>8s} {'method':>9s} {'wall s':>8s} {'cpu s':>8s} {'peak GB':>8s} "
          f"{'wall/s x':>9s} {'cpu/s x':>8s} {'MPJPE mm':>9s}")
    for length, methods in result["reconstruct"].items():
        for method, r in methods.items():
            if "error" in r:
                print(f"{length:>8s} {method:>9s}  failed: {r['error'][0]}")
                continue
            print(f"{length:>8s} {method:>9s} {r['wall_s']:8.1f} {r['cpu_s']:8.1f} {r['peak_bytes'] / GB:8.2f} "
                  f"{r.get('wall_per_s_ratio', float('nan')):9.2f} {r.get('cpu_per_s_ratio', float('nan')):8.2f} "
                  f"{r['MPJPE']:9.2f}")
    print("(x: cost per second of trial relative to the shortest trial; 1.00 = linear)")
    if result["targets"]:
        print("\ntargets:")
        for name, t in result["targets"].items():
            print(f"  {'met ' if t['met'] else 'MISS'}  {name}: {t['value']:.2f}")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, nargs="+", default=[30.0, 120.0, 360.0, 600.0])
    ap.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    ap.add_argument("--cameras", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workdir", type=Path, default=None, help="keep the trials here (default: a temp folder)")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s", stream=sys.stderr)
    with tempfile.TemporaryDirectory(prefix="gaitcap-scaling-") as tmp:
        workdir = args.workdir or Path(tmp)
        result = run(seconds=sorted(args.seconds), methods=args.methods, cameras=args.cameras, seed=args.seed,
                     workdir=workdir)
    emit(result, as_json=args.json, table=print_table)


if __name__ == "__main__":
    main()
