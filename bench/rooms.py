"""Benchmark: one central catalog for several rooms, on SQLite and on PostgreSQL (a throwaway server).

1. The catalog's read queries on ``--trials`` synthetic trials (default 10,000: 2,000 patients with 5 visits,
   two rooms, each trial done with a result of 12 steps and 8 summary values): the patient list, one
   patient's history (the trials, their stages, quality, clinical fields and best values: what the patient
   page reads) and trends (best values of a patient's trials), the newest trials, one room's newest trials.
   Median of ``--repeats`` (ms).
2. Claims: ``--jobs`` queued jobs taken and completed by 1 and 2 claimers at once (their own connections):
   median claim latency (ms) and claims per second.
3. Trials per hour through 1 and 2 real ``gaitcap worker`` processes on the PostgreSQL catalog
   (``--worker-trials`` synthetic 10 s, 4-camera walks, preliminary stage only; workers warmed up first).
   ``--worker-trials 0`` skips it.

    python bench/rooms.py                # table
    python bench/rooms.py --json         # exactly one JSON object on stdout
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from gaitcap.services import catalog as cat  # noqa: E402
from gaitcap.services.catalog import patients as pat  # noqa: E402
from gaitcap.services.catalog import rooms  # noqa: E402
from gaitcap.services.catalog.models import Result, SessionRow, Step, Subject, Summary, Trial  # noqa: E402
from gaitcap.services.ops.pg_server import LocalPostgres  # noqa: E402
from sqlalchemy import insert, text  # noqa: E402

from bench._common import emit  # noqa: E402

SUMMARY = ("gait_speed_m_per_s", "cadence_steps_per_min", "step_length_mm", "step_width_mm", "step_time_s",
           "stance_pct", "swing_pct", "step_length_asymmetry_pct")
ROOMS = ("gait1", "gait2")


def fill(db: cat.Catalog, n_trials: int, *, visits: int = 5) -> str:
    """``n_trials`` done trials in bulk (patients of ``visits`` trials each, rooms in turn); a patient's id."""
    for room in ROOMS:
        rooms.register_room(db, room)
    patients = max(1, n_trials // visits)
    now = time.time() - n_trials * 60.0
    subjects, sessions, trials, results, steps, summaries = [], [], [], [], [], []
    for p in range(patients):
        sid = f"P{p:05d}"
        subjects.append({"id": sid, "created_at": now})
        for v in range(visits):
            i = p * visits + v
            if i >= n_trials:
                break
            tid, at = f"T{i:06d}", now + i * 60.0
            sessions.append({"id": f"{sid}/v{v}", "subject_id": sid, "created_at": at})
            trials.append({"id": tid, "session_id": f"{sid}/v{v}", "subject_id": sid, "state": "done",
                           "room": ROOMS[i % len(ROOMS)], "recording_slot": None, "created_at": at, "updated_at": at,
                           "started_at": at, "stopped_at": at + 30, "recording_path": f"/store/trials/{tid}/r.mcap",
                           "calibration_id": None, "stage": "done", "progress": 1.0, "error": "", "notes": ""})
            results.append({"id": i + 1, "trial_id": tid, "stage": "preliminary", "method": "robust", "created_at": at,
                            "report_json": "{}", "quality_json": "{}", "artifacts_json": "{}"})
            steps += [{"result_id": i + 1, "index": k, "side": "left" if k % 2 else "right", "time_s": 0.55 * k,
                       "values_json": json.dumps({"step_length_mm": 600 + k})} for k in range(12)]
            summaries += [{"result_id": i + 1, "name": name, "value": 1.0 + j + i % 7, "sd": 0.1, "unit": ""}
                          for j, name in enumerate(SUMMARY)]
    with db.session() as s:
        for model, rows in ((Subject, subjects), (SessionRow, sessions), (Trial, trials), (Result, results),
                            (Step, steps), (Summary, summaries)):
            for k in range(0, len(rows), 5000):
                s.execute(insert(model), rows[k:k + 5000])
    if db.engine.dialect.name == "postgresql":  # the numbering goes on after the rows given their ids
        with db.session() as s:
            s.execute(text("SELECT setval(pg_get_serial_sequence('results', 'id'), (SELECT MAX(id) FROM results))"))
            s.execute(text("ANALYZE"))
    return f"P{patients // 2:05d}"


def _ms(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t0) * 1000)
    return round(statistics.median(times), 2)


def history(db: cat.Catalog, subject: str) -> list:
    """What the patient page reads: the patient's trials, their stages, quality, clinical fields, best values."""
    trials = cat.list_trials(db, subject_id=subject, limit=1000)
    ids = [t.id for t in trials]
    return [cat.stages_of(db, ids), cat.qualities_of(db, ids), pat.details_of(db, ids), cat.best_means_of(db, ids)]


def queries(db: cat.Catalog, subject: str, repeats: int) -> dict:
    return {"patient list": _ms(lambda: pat.list_patients(db, limit=200), repeats),
            "history": _ms(lambda: history(db, subject), repeats),
            "trends": _ms(lambda: cat.best_means_of(db, [t.id for t in cat.list_trials(db, subject_id=subject)]),
                          repeats),
            "newest 50 trials": _ms(lambda: cat.list_trials(db, limit=50), repeats),
            "one room's newest 50": _ms(lambda: cat.list_trials(db, limit=50, room="gait2"), repeats)}


def claims(url: str, n_jobs: int, claimers: int) -> dict:
    """``n_jobs`` queued jobs taken and completed by ``claimers`` threads, each on its own connection."""
    db = cat.open_catalog(url)
    with db.session() as s:
        ids = list(s.scalars(text("SELECT id FROM trials ORDER BY id LIMIT :n").bindparams(n=n_jobs)))
    for tid in ids:
        cat.enqueue_job(db, tid)
    latencies, taken, barrier = [], [], threading.Barrier(claimers)

    def work(name):
        mine = cat.open_catalog(url)
        barrier.wait()
        while True:
            t0 = time.perf_counter()
            job = cat.lease_job(mine, name, lease_s=60)
            latencies.append((time.perf_counter() - t0) * 1000)
            if job is None:
                break
            taken.append(job.id)
            cat.complete_job(mine, job.id, name)
        mine.close()

    t0 = time.perf_counter()
    threads = [threading.Thread(target=work, args=(f"c{i}",)) for i in range(claimers)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    wall = time.perf_counter() - t0
    db.close()
    return {"claimers": claimers, "jobs": len(taken), "each once": len(taken) == len(set(taken)) == len(ids),
            "claim_ms": round(statistics.median(latencies), 2), "claims_per_s": round(len(taken) / wall, 1)}


def worker_throughput(pg: LocalPostgres, n_trials: int, n_workers: int, folder: Path) -> dict:
    """Trials per hour through ``n_workers`` real worker processes (preliminary only) on a new catalog."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "services"))
    from conftest import write_trial_mcap
    from gaitcap.simulator import make_trial

    url = pg.create_database(f"workers_{n_workers}")
    db = cat.open_catalog(url)
    walk = make_trial("clean", seconds=10, cameras=4, people=1, seed=3, fps=30)
    data = folder / f"workers-{n_workers}"
    ids = []
    for i in range(n_trials):
        t = cat.start_trial(db, subject_id=f"P{i}", session="v1",
                            recording_path_for=lambda tid: data / "trials" / tid / "recording.mcap")
        write_trial_mcap(walk, Path(t.recording_path))
        cat.set_state(db, t.id, "recorded")  # queued below, once the workers are ready
        ids.append(t.id)
    env = {**os.environ, **pg.environment(), "GAITCAP_CATALOG": url}
    procs, logs = [], []
    for w in range(n_workers):
        log = folder / f"worker-{n_workers}-{w}.log"
        logs.append(log)
        procs.append(subprocess.Popen([sys.executable, "-c", "from gaitcap.services.cli import main; main()", "worker",
                                       "--no-bus", "--no-refine", "--id", f"w{w}", "--data-dir", str(data)],
                                      env=env, stdout=open(log, "w"), stderr=subprocess.STDOUT))
    try:
        deadline = time.monotonic() + 600
        while not all("ready" in log.read_text() for log in logs):
            if time.monotonic() > deadline or any(p.poll() is not None for p in procs):
                raise RuntimeError(f"workers did not start: see {folder}")
            time.sleep(0.5)
        t0 = time.monotonic()
        for tid in ids:
            cat.enqueue_job(db, tid)
        while True:
            states = [cat.get_trial(db, tid).state for tid in ids]
            if all(s in ("done", "done_with_warnings", "failed") for s in states):
                break
            if time.monotonic() > deadline:
                raise RuntimeError(f"trials not finished: {states}")
            time.sleep(0.2)
        wall = time.monotonic() - t0
    finally:
        for p in procs:
            p.terminate()
        for p in procs:
            try:
                p.wait(60)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait(10)
    takers = {j.worker_id for tid in ids for j in cat.jobs_for_trial(db, tid)}
    jobs = sum(len(cat.jobs_for_trial(db, tid)) for tid in ids)
    db.close()
    return {"workers": n_workers, "trials": n_trials, "done": states.count("done") + states.count("done_with_warnings"),
            "jobs": jobs, "workers_used": len(takers), "wall_s": round(wall, 1),
            "trials_per_hour": round(n_trials / wall * 3600, 1)}


def run(args) -> dict:
    out = {"trials": args.trials, "machine": args.machine, "backends": {}}
    folder = Path(tempfile.mkdtemp(prefix="gaitcap-bench-rooms-"))
    try:
        with LocalPostgres() as pg:
            os.environ.update(pg.environment())
            for backend, url in (("sqlite", str(folder / "catalog.sqlite")), ("postgresql", pg.create_database("bench"))):
                db = cat.open_catalog(url)
                t0 = time.perf_counter()
                subject = fill(db, args.trials)
                filled = time.perf_counter() - t0
                row = {"fill_s": round(filled, 1), "queries_ms": queries(db, subject, args.repeats)}
                db.close()
                row["claims"] = [claims(url, args.jobs, n) for n in (1, 2)]
                out["backends"][backend] = row
            out["workers"] = [worker_throughput(pg, args.worker_trials, n, folder) for n in (1, 2)
                              ] if args.worker_trials else []
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return out


def table(r: dict) -> str:
    lines = [f"central catalog, {r['trials']} synthetic trials ({r['machine']})", "",
             f"{'query (median ms)':28s} {'SQLite':>10s} {'PostgreSQL':>11s}"]
    b = r["backends"]
    for name in b["sqlite"]["queries_ms"]:
        lines.append(f"{name:28s} {b['sqlite']['queries_ms'][name]:10.2f} {b['postgresql']['queries_ms'][name]:11.2f}")
    lines += ["", f"{'claims':28s} {'SQLite':>22s} {'PostgreSQL':>22s}"]
    for i, n in enumerate((1, 2)):
        cells = [f"{b[k]['claims'][i]['claim_ms']:6.2f} ms {b[k]['claims'][i]['claims_per_s']:7.1f}/s"
                 + ("" if b[k]["claims"][i]["each once"] else " TWICE!") for k in ("sqlite", "postgresql")]
        lines.append(f"{n} claimer(s), latency, rate  {cells[0]:>22s} {cells[1]:>22s}")
    if r["workers"]:
        lines += ["", "worker processes on PostgreSQL (10 s 4-camera trials, preliminary only)"]
        for w in r["workers"]:
            lines.append(f"  {w['workers']} worker(s): {w['done']}/{w['trials']} done in {w['wall_s']} s, "
                         f"{w['trials_per_hour']} trials/hour, {w['jobs']} jobs, {w['workers_used']} worker(s) used")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=10_000)
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--jobs", type=int, default=300)
    ap.add_argument("--worker-trials", type=int, default=4)
    ap.add_argument("--machine", default="2-core development machine, shared by several sessions")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    emit(run(args), as_json=args.json, table=table)


if __name__ == "__main__":
    main()
