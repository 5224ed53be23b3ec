"""Benchmark: the worker's resident memory over many trials in one process.

Simulates ``--trials`` walks of slightly different lengths (``--seconds`` plus 1/30 s more each trial: every
trial a new frame count, as in a clinic), writes each as the recorder does, and processes them one after
the other with ONE :class:`~gaitcap.services.processing.worker.Worker` (the clinic's code path: both stages,
gait, files, viewer files, kinematics). After each trial it prints the process's resident memory (MB), the
compiled JAX executables held (entries of every jitted function's cache), the resident memory of the process
with its children (the server the .rrd writers are forked from, :mod:`gaitcap.services.processing.viewers.apart`;
as ``bench/soak.py`` counts a process) and what Python allocated (tracemalloc, MB, with ``--tracemalloc``).
The slopes are least-squares fits over the trials after ``--warm-up`` (MB per trial).

    python bench/worker_memory.py --trials 12                      # a table
    python bench/worker_memory.py --trials 12 --json               # one JSON object
    python bench/worker_memory.py --trials 12 --keep-trials 1000   # compiled code never dropped (before)
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from bench._common import emit  # noqa: E402


def slope_per_trial(values: list[float]) -> float:
    """Least-squares slope of ``values`` over their index (units per trial); 0 for fewer than 2."""
    import numpy as np

    if len(values) < 2:
        return 0.0
    return float(np.polyfit(np.arange(len(values), dtype=float), np.asarray(values, float), 1)[0])


def run(args) -> dict:
    from gaitcap.services import catalog as cat
    from gaitcap.services.ops.soak import rss_mb
    from gaitcap.services.processing.artifacts import trial_files
    from gaitcap.services.processing.compiled_code import CompiledCodeLimit, compiled_executables
    from gaitcap.services.processing.worker import Worker, WorkerConfig, resident_mb, warm_worker
    from gaitcap.simulator import make_trial
    from gaitcap.simulator.recording import write_keypoint_recording

    if args.tracemalloc:
        tracemalloc.start(args.frames)
    rows, first_snapshot, grew = [], None, []
    with tempfile.TemporaryDirectory(prefix="gaitcap-worker-memory-") as tmp:
        data = Path(tmp)
        db = cat.open_catalog(data / "catalog.sqlite")
        warm_s = warm_worker(cameras=args.cameras, cache_dir=data / ".jax-cache")
        worker = Worker(WorkerConfig(catalog_url=db.url, data_dir=data, refine=not args.no_refine, lease_s=60,
                                     compiled=CompiledCodeLimit(keep_trials=args.keep_trials)), db=db)
        start_mb = resident_mb()
        for k in range(args.trials):
            seconds = args.seconds + k * args.frames_step / 30.0  # a new frame count each trial (by default)
            walk = make_trial("paper", seconds=seconds, cameras=args.cameras, people=1, seed=k, fps=30.0)
            trial = cat.start_trial(db, subject_id="MEM", session="bench",
                                    recording_path_for=lambda tid: trial_files(data, tid).recording)
            write_keypoint_recording(walk, trial_files(data, trial.id).recording, metadata={"trial_id": trial.id})
            cat.set_state(db, trial.id, "recorded")
            cat.enqueue_job(db, trial.id)
            del walk
            t0 = time.perf_counter()
            worker.run_once()
            row = {"trial": k + 1, "frames": round(seconds * 30), "state": cat.get_trial(db, trial.id).state,
                   "job_s": round(time.perf_counter() - t0, 2), "rss_mb": round(resident_mb(), 1),
                   "compiled": compiled_executables(), "with_children_mb": round(rss_mb(os.getpid()), 1)}
            if args.tracemalloc:
                row["python_mb"] = round(tracemalloc.get_traced_memory()[0] / 1e6, 1)
            rows.append(row)
            logging.getLogger("bench").info("%s", row)
            if args.tracemalloc and k + 1 == args.warm_up:
                first_snapshot = tracemalloc.take_snapshot()
        if first_snapshot is not None and args.top:
            grew = _grown_lines(first_snapshot, tracemalloc.take_snapshot(), top=args.top,
                                trials=args.trials - args.warm_up)
        db.close()
    after = [r["rss_mb"] for r in rows[args.warm_up:]]
    rss = [r["rss_mb"] for r in rows]
    family = [r["with_children_mb"] for r in rows]
    return {"python_grown_after_warm_up": grew, "with_children_first_last_max_mb": [family[0], family[-1], max(family)],
            "with_children_slope_mb_per_trial": slope_per_trial(family[args.warm_up:]),"trials": rows, "warm_s": warm_s, "start_rss_mb": start_mb, "first_rss_mb": rss[0], "last_rss_mb": rss[-1],
            "max_rss_mb": max(rss), "slope_mb_per_trial": slope_per_trial(after), "warm_up": args.warm_up,
            "cameras": args.cameras, "seconds": args.seconds, "keep_trials": args.keep_trials}


def _grown_lines(before, after, *, top: int, trials: int) -> list[dict]:
    """The ``top`` tracebacks whose Python allocations grew most between two snapshots (kB per trial)."""
    keep = [tracemalloc.Filter(False, tracemalloc.__file__)]
    stats = after.filter_traces(keep).compare_to(before.filter_traces(keep), "traceback")
    return [{"kb_per_trial": round(s.size_diff / 1e3 / max(trials, 1), 1), "blocks": s.count_diff,
             "where": [f"{f.filename}:{f.lineno}" for f in s.traceback][-8:]}
            for s in sorted(stats, key=lambda s: -s.size_diff)[:top]]


def _table(r: dict) -> str:
    lines = [f"worker memory: {len(r['trials'])} trials of {r['seconds']:.1f} s + one frame each, {r['cameras']} cameras, "
             f"compiled code of {r['keep_trials']} job(s) kept "
             f"(warm-up compile {r['warm_s']:.1f} s, {r['start_rss_mb']:.0f} MB before the first trial)",
             "trial  frames  state               job s   RSS MB  compiled  with children MB"
             + ("  python MB" if "python_mb" in r["trials"][0] else "")]
    for t in r["trials"]:
        lines.append(f"{t['trial']:5d} {t['frames']:7d}  {t['state']:18s} {t['job_s']:6.1f} {t['rss_mb']:8.0f} "
                     f"{t['compiled']:9d} {t['with_children_mb']:17.0f}" + (f" {t['python_mb']:10.1f}" if "python_mb" in t else ""))
    lines.append(f"RSS first / last / max: {r['first_rss_mb']:.0f} / {r['last_rss_mb']:.0f} / {r['max_rss_mb']:.0f} MB; "
                 f"slope after {r['warm_up']} trials: {r['slope_mb_per_trial']:+.2f} MB per trial; with children "
                 f"{' / '.join(f'{v:.0f}' for v in r['with_children_first_last_max_mb'])} MB, "
                 f"{r['with_children_slope_mb_per_trial']:+.2f} MB per trial")
    for g in r.get("python_grown_after_warm_up", []):
        lines.append(f"python allocations {g['kb_per_trial']:+.1f} kB per trial ({g['blocks']:+d} blocks) at "
                     + " <- ".join(reversed(g["where"])))
    return "\n".join(lines)


def main() -> None:
    from gaitcap.services.processing.compiled_code import CompiledCodeLimit

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trials", type=int, default=12)
    p.add_argument("--seconds", type=float, default=6.0, help="The first trial's walk (s); each next one a frame longer.")
    p.add_argument("--frames-step", type=int, default=1,
                   help="Frames added to each next trial (0: every trial as long as the first).")
    p.add_argument("--cameras", type=int, default=10)
    p.add_argument("--warm-up", type=int, default=3, help="Trials left out of the slope.")
    p.add_argument("--no-refine", action="store_true")
    p.add_argument("--keep-trials", type=int, default=CompiledCodeLimit().keep_trials,
                   help="Jobs whose compiled code the worker keeps (the default is the worker's; a large number: "
                        "never dropped, as before the bound).")
    p.add_argument("--tracemalloc", action="store_true", help="Also Python's own allocations (slower).")
    p.add_argument("--top", type=int, default=0,
                   help="With --tracemalloc: the N places whose allocations grew most after the warm-up.")
    p.add_argument("--frames", type=int, default=12, help="With --tracemalloc: stack frames kept per allocation.")
    p.add_argument("--json", action="store_true")
    args = p.parse_args()
    logging.basicConfig(level=logging.WARNING if args.json else logging.INFO, stream=sys.stderr,
                        format="%(asctime)s %(name)s %(message)s")
    for name in ("gaitcap", "jax", "absl"):
        logging.getLogger(name).setLevel(logging.WARNING)
    emit(run(args), as_json=args.json, table=_table)


if __name__ == "__main__":
    main()
