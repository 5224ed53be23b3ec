"""Benchmark: the recorder's resident memory when the process sending it images is killed and restarted.

A real :class:`~gaitcap.services.nodes.recorder.RecorderNode` in its own process records ``--trials`` short
trials (``--seconds`` each) of a sender process publishing 10 cameras' JPEG frames (240x180 px, about
27 kB) and keypoints at 30 fps on a plain loopback bus; every ``--restart-every`` trials the sender is
killed (SIGKILL, ``--clean``: closed) and started again, as a camera process restarted during a working day.
After each trial it prints the recorder's resident memory (MB), the frames it recorded and the messages it
dropped (its queue full).
``--shared-memory`` turns Zenoh's shared-memory transport back on (as the bus had it before it was turned
off: each life of a sender then left its 16 MB pool mapped in the recorder).

    python bench/bus_memory.py                       # a table
    python bench/bus_memory.py --shared-memory       # as before
    python bench/bus_memory.py --json
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import signal
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from bench._common import emit  # noqa: E402

CAMERAS = [f"cam{i:02d}" for i in range(1, 11)]


def _bus_as_chosen(shared_memory: bool) -> None:
    """With ``shared_memory``, every session of this process opens with Zenoh's shared-memory transport on."""
    if not shared_memory:
        return
    import gaitcap.services.bus.session as session

    plain = session.zenoh_config

    def with_shared_memory(bus, node):
        conf = plain(bus, node)
        conf.insert_json5("transport/shared_memory/enabled", "true")
        return conf

    session.zenoh_config = with_shared_memory


def _recorder(bus, data: str, shared_memory: bool, ready) -> None:
    from gaitcap.services.bus.session import open_session
    from gaitcap.services.nodes.recorder import RecorderNode

    _bus_as_chosen(shared_memory)
    RecorderNode(open_session(bus, "recorder"), bus, data_root=data)
    ready.set()
    while True:
        time.sleep(1.0)


def _sender(bus, shared_memory: bool) -> None:
    import cv2
    from gaitcap.services.bus.messages import ImageFrame, Keypoints
    from gaitcap.services.bus.session import open_session

    _bus_as_chosen(shared_memory)
    s = open_session(bus, "camera-0")
    signal.signal(signal.SIGTERM, lambda *_: (s.close(), os._exit(0)))
    img = (np.random.default_rng(0).random((180, 240)) * 60 + np.linspace(0, 180, 240)[None]).astype(np.uint8)
    jpeg = cv2.imencode(".jpg", img)[1].tobytes()
    people = [[[float(i), 2.0, 0.5] for i in range(26)]]
    frame, t0 = 0, time.monotonic()
    while True:
        frame += 1
        now = time.time_ns()
        for cam in CAMERAS:
            f = ImageFrame.build(jpeg, camera=cam, timestamp_ns=now, frame_id=frame, sent_ns=now)
            s.put(bus.keys.image(cam), f.payload, attachment=f.meta.to_bytes())
            s.put(bus.keys.keypoints(cam), Keypoints(cam, frame, now, "halpe26", people).to_bytes())
        time.sleep(max(0.0, t0 + frame / 30.0 - time.monotonic()))


def _rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmRSS")) / 1024


def run(args) -> dict:
    from gaitcap.services.bus.control import RecorderClient
    from gaitcap.services.bus.session import BusConfig, open_session

    bus = BusConfig.free_local(["recorder", "camera-0", "api"], prefix="gaitcap/busmemory")
    data = tempfile.mkdtemp(prefix="gaitcap-bus-memory-")
    ctx = mp.get_context("spawn")
    ready = ctx.Event()
    recorder = ctx.Process(target=_recorder, args=(bus, data, args.shared_memory, ready), daemon=True)
    recorder.start()
    ready.wait(120)
    start_sender = lambda: ctx.Process(target=_sender, args=(bus, args.shared_memory), daemon=True)  # noqa: E731
    sender = start_sender()
    sender.start()
    client = RecorderClient(open_session(bus, "api"), bus.keys, timeout_s=30)
    time.sleep(3.0)
    rows = []
    try:
        for k in range(args.trials):
            restarted = k > 0 and k % args.restart_every == 0
            if restarted:
                os.kill(sender.pid, signal.SIGTERM if args.clean else signal.SIGKILL)
                sender.join()
                sender = start_sender()
                sender.start()
                time.sleep(3.0)
            trial = f"t{k:04d}"
            os.makedirs(os.path.join(data, trial))
            client.start(trial_id=trial, path=f"{trial}/recording.mcap", cameras=CAMERAS)
            time.sleep(args.seconds)
            summary = client.stop(trial).summary
            os.remove(os.path.join(data, trial, "recording.mcap"))
            time.sleep(1.0)
            rows.append({"trial": k + 1, "sender_restarted": restarted, "frames": summary.get("frames"),
                         "dropped": sum((summary.get("dropped_frames") or {}).values()),
                         "recorder_rss_mb": round(_rss_mb(recorder.pid), 1)})
    finally:
        sender.kill()
        recorder.kill()
    rss = [r["recorder_rss_mb"] for r in rows]
    restarts = sum(r["sender_restarted"] for r in rows)
    return {"trials": rows, "shared_memory": args.shared_memory, "clean": args.clean, "restarts": restarts,
            "first_last_max_mb": [rss[0], rss[-1], max(rss)],
            "mb_per_restart": round((rss[-1] - rss[0]) / restarts, 2) if restarts else None}


def _table(r: dict) -> str:
    how = "closed" if r["clean"] else "killed"
    lines = [f"recorder memory, sender {how} and restarted {r['restarts']} times, Zenoh shared memory "
             f"{'on' if r['shared_memory'] else 'off'}", "trial  restarted  frames  dropped  recorder RSS MB"]
    lines += [f"{t['trial']:5d}  {'yes' if t['sender_restarted'] else '':9s}  {t['frames']:6d}  {t['dropped']:7d}  {t['recorder_rss_mb']:15.1f}"
              for t in r["trials"]]
    first, last, top = r["first_last_max_mb"]
    lines.append(f"first / last / max: {first:.1f} / {last:.1f} / {top:.1f} MB; {r['mb_per_restart']:+.1f} MB per restart")
    return "\n".join(lines)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trials", type=int, default=10)
    p.add_argument("--seconds", type=float, default=4.0, help="Each trial records this long (s).")
    p.add_argument("--restart-every", type=int, default=3, help="The sender is restarted before every N-th trial.")
    p.add_argument("--clean", action="store_true", help="Close the sender's session (SIGTERM) instead of SIGKILL.")
    p.add_argument("--shared-memory", action="store_true", help="Zenoh's shared-memory transport on (as before).")
    p.add_argument("--json", action="store_true")
    args = p.parse_args()
    emit(run(args), as_json=args.json, table=_table)


if __name__ == "__main__":
    main()
