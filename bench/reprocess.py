"""Benchmark: batch reprocessing throughput per executor (in-process, local process pool, local Ray).

Writes ``--trials`` synthetic trials (``--seconds`` s, ``--cameras`` cameras, "paper" noise) as
recorded trial MCAPs with their ground truth into a fresh catalog per executor, then runs every
``--method`` over them and reports wall time, tasks/s, the mean compute time per task (inside the
worker, first tasks include JAX compilation) and whether the stored results equal those of the first
executor (they should: workers compute with one XLA thread each).

    python bench/reprocess.py                                 # a table
    python bench/reprocess.py --json                          # one JSON object on stdout
    python bench/reprocess.py --trials 8 --executors pool,ray --workers 2 --method robust --method dlt
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from pathlib import Path


def write_trials(data_dir: Path, trials: list) -> None:
    """The synthetic trials as recorded trials (MCAP of keypoints + calibration, ground_truth.npz)."""
    from gaitcap.services import catalog as cat
    from gaitcap.services.processing.artifacts import trial_files
    from gaitcap.simulator import save_trial
    from gaitcap.simulator.recording import write_keypoint_recording

    db = cat.open_catalog(data_dir / "catalog.sqlite")
    for i, trial in enumerate(trials):
        t = cat.start_trial(db, subject_id="BENCH", session="s1", trial_id=f"bench-{i:03d}",
                            recording_path_for=lambda tid: trial_files(data_dir, tid).recording)
        path = trial_files(data_dir, t.id).recording
        write_keypoint_recording(trial, path, metadata={"trial_id": t.id})
        with tempfile.TemporaryDirectory() as tmp:
            save_trial(trial, tmp)
            shutil.copy(Path(tmp) / "ground_truth.npz", path.parent / "ground_truth.npz")
        cat.set_state(db, t.id, "recorded")
    db.close()


def executors(workers: int) -> dict:
    from gaitcap.services.research.executors import Inline, LocalPool, RayCluster

    return {"inline": Inline(), "pool": LocalPool(workers=workers),
            "ray": RayCluster(address="local", local_cpus=workers)}


def run_one(name: str, executor, data_dir: Path, specs) -> dict:
    from gaitcap.services import catalog as cat
    from gaitcap.services.catalog.method_results import list_results
    from gaitcap.services.research.reprocess import TrialSelection, plan_reprocess, run_plan

    db = cat.open_catalog(data_dir / "catalog.sqlite")
    cache = None if name == "inline" else data_dir / ".jax-cache"
    plan = plan_reprocess(db, data_dir, TrialSelection(), specs, write_files=False, compile_cache=cache)
    t0 = time.perf_counter()
    with executor.open() as ex:
        summary = run_plan(plan, ex)
    wall = time.perf_counter() - t0
    results = list_results(db)
    return {"executor": name, "tasks": len(plan.tasks), "failed": summary.failed, "wall_s": wall,
            "tasks_per_s": len(plan.tasks) / wall,
            "mean_task_s": sum(r.elapsed_s for r in results) / max(len(results), 1),
            "_results": {(r.trial_id, r.params_key): r.comparable() for r in results}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=4)
    ap.add_argument("--seconds", type=float, default=15.0)
    ap.add_argument("--cameras", type=int, default=10)
    ap.add_argument("--method", action="append", default=None, help="default: robust, dlt")
    ap.add_argument("--executors", default="inline,pool,ray")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()

    from gaitcap.services.research.method_specs import parse_method
    from gaitcap.simulator import make_trial

    specs = [parse_method(m) for m in (args.method or ["robust", "dlt"])]
    trials = [make_trial("paper", seconds=args.seconds, cameras=args.cameras, seed=100 + i, fps=30.0)
              for i in range(args.trials)]
    table, reference = [], None
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.executors.split(","):
            data_dir = Path(tmp) / name
            write_trials(data_dir, trials)
            row = run_one(name, executors(args.workers)[name], data_dir, specs)
            results = row.pop("_results")
            reference = reference or results
            row["same_results_as_first"] = results == reference
            table.append(row)
    out = {"trials": args.trials, "seconds": args.seconds, "cameras": args.cameras, "workers": args.workers,
           "methods": [s.name for s in specs], "runs": table}
    if args.json:
        print(json.dumps(out))
        return
    print(f"{args.trials} trials x {len(specs)} methods ({', '.join(out['methods'])}), {args.seconds:.0f} s, "
          f"{args.cameras} cameras, {args.workers} workers")
    print(f"{'executor':10s} {'tasks':>5s} {'wall s':>8s} {'tasks/s':>8s} {'task s':>8s} {'same':>5s}")
    for r in table:
        print(f"{r['executor']:10s} {r['tasks']:5d} {r['wall_s']:8.1f} {r['tasks_per_s']:8.2f} "
              f"{r['mean_task_s']:8.2f} {str(r['same_results_as_first']):>5s}")


if __name__ == "__main__":
    main()
