"""A long trial through the clinic's worker: a six- or ten-minute walk, recorded as the recorder writes it,
processed as after Stop (preliminary robust triangulation, refined default fit, gait, files, viewer files,
joint kinematics).

Prints per stage the seconds from the job's start until it was stored, the worker's peak memory and the
step counts; ``--json`` prints one JSON object. Run it on a quiet machine: the figures are wall times.

    python bench/long_trial.py [--seconds 600] [--cameras 10] [--json]
"""

from __future__ import annotations

import argparse
import logging
import resource
import tempfile
import time
from pathlib import Path

from _common import add_trial_args, emit


def run(*, seconds: float, cameras: int, preset: str, seed: int) -> dict:
    from gaitcap.services import catalog as cat
    from gaitcap.services.processing.artifacts import trial_files
    from gaitcap.services.processing.worker import Worker, WorkerConfig
    from gaitcap.simulator import make_trial
    from gaitcap.simulator.recording import write_keypoint_recording

    t0 = time.perf_counter()
    walk = make_trial(preset, seconds=seconds, cameras=cameras, people=1, seed=seed, fps=30.0)
    simulate_s = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp)
        db = cat.open_catalog(data / "catalog.sqlite")
        trial = cat.start_trial(db, subject_id="BENCH", session="long",
                                recording_path_for=lambda tid: trial_files(data, tid).recording)
        t0 = time.perf_counter()
        path = write_keypoint_recording(walk, trial_files(data, trial.id).recording, metadata={"trial_id": trial.id})
        write_s = time.perf_counter() - t0
        cat.set_state(db, trial.id, "recorded")
        cat.enqueue_job(db, trial.id)
        worker = Worker(WorkerConfig(catalog_url=db.url, data_dir=data, refine=True, lease_s=30), db=db)
        start_wall, start = time.time(), time.perf_counter()
        worker.run_once()
        total_s = time.perf_counter() - start
        final = cat.get_trial(db, trial.id)
        results = {stage: cat.get_result(db, trial.id, stage) for stage in ("preliminary", "refined")}
        stored = {stage: r.created_at - start_wall for stage, r in results.items() if r is not None}  # stored after s
        out = {
            "seconds": seconds, "cameras": cameras, "frames": int(walk.times_s.size),
            "recording_mb": path.stat().st_size / 1e6, "simulate_s": simulate_s, "write_recording_s": write_s,
            "preliminary_s": stored.get("preliminary"), "refined_s": stored.get("refined"), "job_s": total_s,
            "state": final.state, "error": final.error,
            "steps": {stage: len(r.steps) if r else 0 for stage, r in results.items()},
            "true_steps": int(len(walk.truth.steps.foot)),
            "peak_rss_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6,
        }
        db.close()
    return out


def table(r: dict) -> str:
    def s(x):
        return "-" if x is None else f"{x:.1f} s"

    return "\n".join([
        f"long trial: {r['seconds']:.0f} s walk, {r['cameras']} cameras, {r['frames']} frames "
        f"(recording {r['recording_mb']:.0f} MB, written in {r['write_recording_s']:.1f} s)",
        f"  preliminary results stored {s(r['preliminary_s'])} after the job started",
        f"  refined results stored     {s(r['refined_s'])}",
        f"  job finished               {s(r['job_s'])}  -> {r['state']} {r['error']}".rstrip(),
        f"  steps preliminary / refined / true: {r['steps']['preliminary']} / {r['steps']['refined']} / "
        f"{r['true_steps']}",
        f"  peak memory of the process {r['peak_rss_gb']:.2f} GB",
    ])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_trial_args(ap, seconds=600.0)
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    result = run(seconds=args.seconds, cameras=args.cameras, preset=args.preset, seed=args.seed)
    emit(result, as_json=args.json, table=table)


if __name__ == "__main__":
    main()
