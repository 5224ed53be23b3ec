"""Benchmark: Stop -> results per capture room while the other room records, on one central PostgreSQL
catalog (a throwaway server). Two rooms, each a real stack (simulated cameras, detector, recorder, one
worker, the API; every one its own process), both registered with the same catalog. For each room: a trial
recorded and stopped with the other room idle (its quiet figure), then the same with the other room
recording all the while; Stop -> preliminary and -> refined as the room's page sees them (its status
WebSocket, as ``bench/turnaround.py`` watches it). A first trial per room warms its worker up (not counted).

    python bench/rooms_turnaround.py                  # table (8 s trials, 4 cameras a room)
    python bench/rooms_turnaround.py --json           # exactly one JSON object on stdout
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from contextlib import ExitStack
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from gaitcap.services.bus.session import free_loopback_ports  # noqa: E402
from gaitcap.services.ops.auto_trial import start_when_ready  # noqa: E402
from gaitcap.services.ops.pg_server import LocalPostgres  # noqa: E402
from gaitcap.services.ops.stack import Stack, StackConfig  # noqa: E402

from bench._common import emit  # noqa: E402
from bench.turnaround import watch_trial  # noqa: E402

TOKEN = "rooms-turnaround-bench-token"
ROOMS = ("gait1", "gait2")


def _room(tmp: str, url: str, name: str, base: int, args) -> StackConfig:
    return StackConfig(data_dir=Path(tmp) / name, token=TOKEN, port=base, bus_base_port=base + 1,
                       cameras=args.cameras, size=args.size, fps=args.fps, sim_seconds=600.0, workers=1,
                       catalog_url=url, room=name)


def _measure(client, cfg: StackConfig, other_client, *, subject: str, seconds: float, timeout_s: float) -> dict:
    """One trial of ``client``'s room, the other room recording meanwhile when ``other_client`` is given."""
    other = start_when_ready(other_client, {"subject_id": f"{subject}-OTHER"}) if other_client else None
    try:
        cookie = {"Cookie": f"gaitcap_session={client.cookies['gaitcap_session']}"}
        row = watch_trial(f"ws://{cfg.host}:{cfg.port}/ws/status", client, cookie, subject=subject,
                          seconds=seconds, timeout_s=timeout_s)
    finally:
        if other is not None:
            other_client.post(f"/trials/{other}/stop").raise_for_status()
    row["other_room_recording"] = other is not None
    return row


def run(args) -> dict:
    rows = []
    with tempfile.TemporaryDirectory(prefix="gaitcap-rooms-turnaround-") as tmp, LocalPostgres() as pg:
        url = pg.create_database("rooms")
        os.environ.update(pg.environment())  # the password file, for the stacks' APIs and workers
        ports = free_loopback_ports(40)
        cfgs = {name: _room(tmp, url, name, ports[20 * k], args) for k, name in enumerate(ROOMS)}
        t0 = time.monotonic()
        with ExitStack() as stack:
            stacks = {name: stack.enter_context(Stack(cfg)) for name, cfg in cfgs.items()}
            started_s = time.monotonic() - t0
            clients = {name: stack.enter_context(s.client(timeout_s=60)) for name, s in stacks.items()}
            for name in ROOMS:  # a first trial per room compiles the fits: not counted
                _measure(clients[name], cfgs[name], None, subject=f"{name.upper()}-WARM", seconds=args.seconds,
                         timeout_s=args.timeout)
            for name, other in zip(ROOMS, reversed(ROOMS), strict=True):
                for busy in (False, True):
                    row = _measure(clients[name], cfgs[name], clients[other] if busy else None,
                                   subject=f"{name.upper()}-{int(busy)}", seconds=args.seconds, timeout_s=args.timeout)
                    row["room"] = name
                    rows.append(row)
                    print(f"{name}, other room {'recording' if busy else 'idle'}: {row}", file=sys.stderr)
    return {"rooms": list(ROOMS), "cameras_per_room": args.cameras, "size": args.size, "fps": args.fps,
            "seconds_recorded": args.seconds, "stacks_start_s": round(started_s, 1), "cpu_cores": os.cpu_count(),
            "load_average_1min": round(os.getloadavg()[0], 1), "trials": rows}


def _f(v) -> str:
    return "never" if v is None else f"{v:.1f}"


def table(r: dict) -> str:
    lines = [f"Two rooms on one PostgreSQL catalog, {r['cameras_per_room']} cameras a room ({r['size']} px, "
             f"{r['fps']:g} fps), {r['seconds_recorded']:g} s trials, {r['cpu_cores']} CPU cores, "
             f"stacks up in {r['stacks_start_s']} s",
             f"{'room':<6} {'other room':<10} {'state':<20} {'Stop->prelim s':>14} {'Stop->refined s':>15}"]
    for t in r["trials"]:
        lines.append(f"{t['room']:<6} {'recording' if t['other_room_recording'] else 'idle':<10} "
                     f"{str(t['state']):<20} {_f(t['preliminary_s']):>14} {_f(t['refined_s']):>15}")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=8.0, help="recording length of each trial (s)")
    ap.add_argument("--cameras", type=int, default=4, help="simulated cameras per room")
    ap.add_argument("--size", default="160x120", help="simulated image size (px)")
    ap.add_argument("--fps", type=float, default=15.0)
    ap.add_argument("--timeout", type=float, default=300.0, help="per trial, after Stop (s)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    emit(run(args), as_json=args.json, table=table)


if __name__ == "__main__":
    main()
