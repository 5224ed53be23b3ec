"""Benchmark: Stop -> metrics on the clinic page, with the whole stack running as real processes.

Starts the stack (simulated 10-camera rig rendering live, simulated detector, recorder, worker, API, Zenoh
peers on loopback), then for each trial: Start over REST, record ``--seconds`` of walking, Stop, and
watch the page's status WebSocket (what the page itself listens to, every 0.5 s) until the trial lists
its preliminary and then its refined results. Targets for a 30 s trial: preliminary <= 3 s, refined
<= 20 s after Stop.

    python bench/turnaround.py                 # table (2 trials of 30 s)
    python bench/turnaround.py --json          # exactly one JSON object on stdout
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from gaitcap.services.ops.auto_trial import FINISHED, start_when_ready  # noqa: E402

TARGET_PRELIMINARY_S, TARGET_REFINED_S = 3.0, 20.0


def watch_trial(ws_url: str, client, cookie: dict, *, subject: str, seconds: float, timeout_s: float) -> dict:
    """Start, record, stop; seconds from Stop until the page's status shows each result stage."""
    from websockets.sync.client import connect

    tid = start_when_ready(client, {"subject_id": subject})
    time.sleep(seconds)
    t_stop = time.monotonic()
    client.post(f"/trials/{tid}/stop").raise_for_status()
    stop_call_s = time.monotonic() - t_stop
    seen: dict[str, float] = {}
    trial: dict = {}
    with connect(ws_url, additional_headers=cookie) as ws:
        while time.monotonic() - t_stop < timeout_s:
            snap = json.loads(ws.recv(timeout=timeout_s))
            trial = next((t for t in snap["trials"] if t["id"] == tid), trial)
            for stage in trial.get("results", []):
                seen.setdefault(stage, time.monotonic() - t_stop)
            if trial.get("state") in FINISHED:
                break
    return {"trial_id": tid, "state": trial.get("state"), "error": trial.get("error", ""),
            "stop_call_s": stop_call_s, "preliminary_s": seen.get("preliminary"), "refined_s": seen.get("refined")}


def compute_times(catalog_url: str, trial_id: str) -> dict:
    from gaitcap.services import catalog as cat

    db = cat.open_catalog(catalog_url)
    out = {}
    for stage in ("preliminary", "refined"):
        r = cat.get_result(db, trial_id, stage)
        if r is not None:
            out[f"{stage}_compute_s"] = r.report.get("compute_s")
            out[f"{stage}_load_s"] = r.report.get("load_s")
            out[f"{stage}_gait_files_s"] = r.report.get("gait_and_files_s")
            out[f"{stage}_steps"] = len(r.steps)
    trial, job = cat.get_trial(db, trial_id), cat.jobs_for_trial(db, trial_id)[0]
    with db.session() as s:
        from gaitcap.services.catalog.models import Job

        started = s.get(Job, job.id).started_at
    out["queue_s"] = None if started is None or trial.stopped_at is None else started - trial.stopped_at
    db.close()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=30.0, help="recording length of each trial (s)")
    parser.add_argument("--trials", type=int, default=2)
    parser.add_argument("--cameras", type=int, default=10)
    parser.add_argument("--size", default="240x180", help="simulated image size (px)")
    parser.add_argument("--timeout", type=float, default=300.0, help="per trial, after Stop (s)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)

    from gaitcap.services.bus.session import free_loopback_ports
    from gaitcap.services.ops.stack import Stack, StackConfig

    base = free_loopback_ports(16)[0]
    with tempfile.TemporaryDirectory(prefix="gaitcap-turnaround-") as tmp:
        cfg = StackConfig(data_dir=Path(tmp), token="turnaround-bench-token", port=base, bus_base_port=base + 1,
                          cameras=args.cameras, size=args.size, sim_seconds=max(300.0, 3 * args.seconds))
        t0 = time.monotonic()
        with Stack(cfg) as stack:
            startup_s = time.monotonic() - t0
            ws_url = f"ws://{cfg.host}:{cfg.port}/ws/status"
            rows = []
            with stack.client(timeout_s=60) as c:
                cookie = {"Cookie": f"gaitcap_session={c.cookies['gaitcap_session']}"}
                for i in range(args.trials):
                    row = watch_trial(ws_url, c, cookie, subject=f"BENCH{i}", seconds=args.seconds, timeout_s=args.timeout)
                    row.update(compute_times(cfg.catalog, row["trial_id"]))
                    rows.append(row)
                    print(f"trial {i}: {row}", file=sys.stderr)
            del stack
    result = summarise(rows, args, startup_s)
    if args.json:
        print(json.dumps(result))
    else:
        print_table(result)


def summarise(rows: list[dict], args, startup_s: float) -> dict:
    def worst(key):
        vals = [r[key] for r in rows]
        return None if any(v is None for v in vals) else max(vals)

    return {
        "seconds_recorded": args.seconds, "cameras": args.cameras, "image_size": args.size, "trials": rows,
        "stack_startup_s": round(startup_s, 1), "cpu_cores": os.cpu_count(),
        "preliminary_s_worst": worst("preliminary_s"), "refined_s_worst": worst("refined_s"),
        "target_preliminary_s": TARGET_PRELIMINARY_S, "target_refined_s": TARGET_REFINED_S,
        "preliminary_ok": (worst("preliminary_s") or 1e9) <= TARGET_PRELIMINARY_S,
        "refined_ok": (worst("refined_s") or 1e9) <= TARGET_REFINED_S,
        "note": "Stop -> the page's status WebSocket (0.5 s period) lists the result stage; the stack's live "
                "simulated cameras keep rendering meanwhile; shared machine, timings noisy",
    }


def _fmt(v) -> str:
    return "never" if v is None else f"{v:.2f}"


def print_table(result: dict) -> None:
    print(f"Turnaround, {result['seconds_recorded']:.0f} s trials, {result['cameras']} simulated cameras "
          f"({result['image_size']} px), {result['cpu_cores']} CPU cores; stack start-up {result['stack_startup_s']} s")
    print(f"{'trial':<26} {'stop call s':>11} {'prelim s':>9} {'refined s':>10} {'prelim compute s':>17} "
          f"{'refined compute s':>18} {'steps p/r':>10}")
    for r in result["trials"]:
        print(f"{r['trial_id']:<26} {_fmt(r['stop_call_s']):>11} {_fmt(r['preliminary_s']):>9} "
              f"{_fmt(r['refined_s']):>10} {_fmt(r.get('preliminary_compute_s')):>17} "
              f"{_fmt(r.get('refined_compute_s')):>18} "
              f"{r.get('preliminary_steps', 0)}/{r.get('refined_steps', 0):>3}")
    print(f"worst: preliminary {_fmt(result['preliminary_s_worst'])} s (target <= {TARGET_PRELIMINARY_S:.0f}: "
          f"{'met' if result['preliminary_ok'] else 'MISSED'}), refined {_fmt(result['refined_s_worst'])} s "
          f"(target <= {TARGET_REFINED_S:.0f}: {'met' if result['refined_ok'] else 'MISSED'})")
    print(result["note"])


if __name__ == "__main__":
    main()
