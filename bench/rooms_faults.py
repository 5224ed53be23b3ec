"""Benchmark: faults across hosts on a capture room's real stack (simulated cameras, detector, recorder, two
workers, the API; every one its own process) whose catalog is a central PostgreSQL server (a throwaway one).

1. The database server stopped for ``--outage-s`` (default 60 s) while the room records: the recording goes
   on, /health (the page's banner) says the catalog is unreachable, Stop pressed half-way through the outage
   answers at once (202, the recording saved) and its catalog writes wait; once the server is back: how long
   until the trial is ``recorded`` and then processed, with nobody pressing anything again.
2. A worker killed (SIGKILL) while it processes a trial: another worker (or the restarted one) takes it once
   the lease has run out and finishes it: its attempts and how long after the kill.
3. Trials lost: recordings of these trials without their file, or trials that did not end processed.

    python bench/rooms_faults.py                 # table (the 60 s outage; about 4 min on the dev machine)
    python bench/rooms_faults.py --outage-s 10   # shorter
    python bench/rooms_faults.py --json          # exactly one JSON object on stdout
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from gaitcap.services import catalog as cat  # noqa: E402
from gaitcap.services.bus.session import free_loopback_ports  # noqa: E402
from gaitcap.services.ops.auto_trial import FINISHED, start_when_ready  # noqa: E402
from gaitcap.services.ops.pg_server import LocalPostgres  # noqa: E402
from gaitcap.services.ops.stack import Stack, StackConfig  # noqa: E402

from bench._common import emit  # noqa: E402

TOKEN = "rooms-faults-bench-token-1"


def _until(what: str, predicate, timeout_s: float, poll_s: float = 0.25):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        try:
            got = predicate()
        except Exception:  # the catalog (or the API) not answering yet: ask again
            got = None
        if got:
            return got
        time.sleep(poll_s)
    raise RuntimeError(f"timed out after {timeout_s:.0f} s waiting for {what}")


def _state(db: cat.Catalog, trial_id: str) -> str:
    return cat.get_trial(db, trial_id).state


def outage(client, pg: LocalPostgres, db: cat.Catalog, outage_s: float) -> dict:
    """Stop the database server for ``outage_s`` while the room records; Stop half-way."""
    trial_id = start_when_ready(client, {"subject_id": "P0001"}, ready_timeout_s=60)
    time.sleep(3.0)
    pg.pause()
    t_down = time.monotonic()
    said, recorder_alive = set(), 0
    stop_code, stop_detail, stop_call_s = None, "", None
    while time.monotonic() - t_down < outage_s:
        health = client.get("/health").json()["components"]
        said.add(health["database"]["status"].split(" (")[0])
        recorder_alive += bool(health["recorder"]["ok"])
        if stop_code is None and time.monotonic() - t_down >= outage_s / 2:
            t0 = time.monotonic()
            r = client.post(f"/trials/{trial_id}/stop")
            stop_call_s, stop_code, stop_detail = time.monotonic() - t0, r.status_code, r.json().get("detail", "")
        time.sleep(1.0)
    pg.resume()
    t_up = time.monotonic()
    _until("the pending Stop written", lambda: _state(db, trial_id) not in ("recording", "stopping"), 60)
    written_s = time.monotonic() - t_up
    final = _until("the trial processed", lambda: _state(db, trial_id) in FINISHED and _state(db, trial_id), 600)
    trial = cat.get_trial(db, trial_id)
    frames = cat.get_quality(db, trial_id).get("recorder", {}).get("frames")
    return {"trial": trial_id, "outage_s": outage_s, "database_said": sorted(said), "stop_status": stop_code,
            "stop_call_s": stop_call_s, "stop_detail": stop_detail, "recorder_up_polls": recorder_alive,
            "recorded_s": trial.duration_s, "frames": frames, "written_after_resume_s": written_s,
            "processed_after_resume_s": time.monotonic() - t_up, "state": final, "error": trial.error}


def worker_killed(stack: Stack, client, db: cat.Catalog, seconds: float) -> dict:
    """Record ``seconds``, Stop, SIGKILL the worker process that took the trial once it is processing (its
    supervisor starts it again; the job's lease runs out first)."""
    trial_id = start_when_ready(client, {"subject_id": "P0002"}, ready_timeout_s=60)
    time.sleep(seconds)
    r = client.post(f"/trials/{trial_id}/stop")
    if r.status_code != 200:
        raise RuntimeError(f"stop failed ({r.status_code}): {r.text}")
    job = _until("a worker processing the trial",
                 lambda: next((j for j in cat.jobs_for_trial(db, trial_id) if j.state == "running"), None), 300, 0.05)
    _until("the trial processing", lambda: _state(db, trial_id) == "processing", 60, 0.05)
    killed = job.worker_id  # the stack names each worker process and its catalog id alike
    if killed not in stack.cfg.worker_names():
        raise RuntimeError(f"the trial is held by {killed!r}, not one of the stack's workers")
    pid = stack.supervisor.pid(killed)
    stack.supervisor.kill(killed, signal.SIGKILL)
    t_kill = time.monotonic()
    final = _until("the trial processed", lambda: _state(db, trial_id) in FINISHED and _state(db, trial_id), 900)
    last = cat.jobs_for_trial(db, trial_id)[-1]
    return {"trial": trial_id, "killed": f"{killed} (pid {pid})", "finished_by": last.worker_id, "attempts": last.attempts,
            "finished_after_kill_s": time.monotonic() - t_kill, "state": final,
            "error": cat.get_trial(db, trial_id).error}


def lost(db: cat.Catalog, trial_ids: list[str]) -> list[str]:
    """The trials without their recording file or not processed."""
    return [t for t in trial_ids if not Path(cat.get_trial(db, t).recording_path).is_file()
            or _state(db, t) not in ("done", "done_with_warnings")]


def run(args) -> dict:
    with tempfile.TemporaryDirectory(prefix="gaitcap-rooms-faults-") as tmp, LocalPostgres() as pg:
        url = pg.create_database("faults")
        os.environ.update(pg.environment())  # the password file, for the stack's API and workers
        base = free_loopback_ports(12)[0]
        cfg = StackConfig(data_dir=Path(tmp) / "gait1", token=TOKEN, port=base, bus_base_port=base + 1,
                          cameras=args.cameras, size="160x120", fps=15.0, sim_seconds=600.0, lease_s=4.0, workers=2,
                          refine=False, catalog_url=url, room="gait1")
        stack = Stack(cfg)
        t0 = time.monotonic()
        stack.start(timeout_s=300)
        started_s = time.monotonic() - t0
        db = cat.open_catalog(url)
        try:
            with stack.client() as client:
                down = outage(client, pg, db, args.outage_s)
                kill = worker_killed(stack, client, db, args.seconds)
            missing = lost(db, [down["trial"], kill["trial"]])
        finally:
            db.close()
            stack.stop()
    return {"stack_start_s": started_s, "cameras": args.cameras, "outage": down, "worker_killed": kill,
            "trials": 2, "lost": missing}


def table(r: dict) -> str:
    d, k = r["outage"], r["worker_killed"]
    rows = [
        ("stack start (s)", f"{r['stack_start_s']:.0f}"),
        ("database stopped for (s)", f"{d['outage_s']:.0f}"),
        ("/health said", "; ".join(d["database_said"])),
        ("recorder up during the outage (polls)", str(d["recorder_up_polls"])),
        ("Stop during the outage", f"{d['stop_status']} in {d['stop_call_s']:.2f} s"),
        ("trial recorded (s, frames)", f"{d['recorded_s']:.1f}, {d['frames']}"),
        ("Stop written after the server is back (s)", f"{d['written_after_resume_s']:.1f}"),
        ("processed after the server is back (s)", f"{d['processed_after_resume_s']:.1f} ({d['state']})"),
        ("worker killed mid-trial", k["killed"]),
        ("finished by (attempt)", f"{k['finished_by']} ({k['attempts']})"),
        ("finished after the kill (s)", f"{k['finished_after_kill_s']:.1f} ({k['state']})"),
        ("trials lost", f"{len(r['lost'])} of {r['trials']}"),
    ]
    width = max(len(a) for a, _ in rows)
    return "\n".join(f"{a:<{width}}  {b}" for a, b in rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--outage-s", type=float, default=60.0, help="How long the database server is stopped (s).")
    ap.add_argument("--seconds", type=float, default=8.0, help="The walk recorded for the worker-kill trial (s).")
    ap.add_argument("--cameras", type=int, default=4)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    emit(run(args), as_json=args.json, table=table)


if __name__ == "__main__":
    main()
