"""Benchmark: frames delivered per simulated camera while the whole demo stack runs and records a trial.

Starts the demo stack as ``gaitcap demo`` does (simulated 10-camera rig rendering live, simulated detector,
recorder, worker, API; Zenoh peers on loopback), optionally loads the machine with ``--burn`` busy
processes, records one ``--seconds`` trial through the REST API and counts every image on the bus per
camera meanwhile: delivered fps (frames in the recording window / window s; target >= 28 of 30), frame id
gaps, and how late the camera node published each frame after its own timestamp (ms). The target is met
only when every camera delivers and the trial ends ``done`` (no data-quality warnings). Then reads what the
recorder wrote per camera (its summary) and the trial's finished state and data-quality warnings.

    python bench/demo_cameras.py                      # 20 s trial, a table
    python bench/demo_cameras.py --burn 1 --json      # with one busy process beside it, one JSON object
"""

from __future__ import annotations

import argparse
import logging
import multiprocessing
import os
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from bench._common import emit  # noqa: E402

TARGET_FPS = 28.0


class ImageCounter:
    """Counts image messages per camera (frame ids, publish lag ms) while :attr:`counting` is set."""

    def __init__(self) -> None:
        self.counting = threading.Event()
        self.frame_ids: dict[str, list[int]] = {}
        self.lag_ms: dict[str, list[float]] = {}
        self._lock = threading.Lock()

    def __call__(self, sample) -> None:
        from gaitcap.acquisition.encoding import parse_image_message
        from gaitcap.services.bus.messages import FrameMeta

        if not self.counting.is_set():
            return
        meta = FrameMeta.from_bytes(sample.attachment.to_bytes())
        msg = parse_image_message(sample.payload.to_bytes())
        with self._lock:
            self.frame_ids.setdefault(msg.camera, []).append(meta.frame_id)
            self.lag_ms.setdefault(msg.camera, []).append((meta.sent_ns - msg.timestamp_ns) / 1e6)


def _burn(stop) -> None:
    while not stop.is_set():
        sum(i * i for i in range(10_000))


def record_trial(stack, counter: ImageCounter, *, seconds: float, timeout_s: float) -> tuple[dict, float]:
    """Start a trial, count images for ``seconds``, stop, wait until it is finished: (trial, window s)."""
    from gaitcap.services.ops.auto_trial import FINISHED, start_when_ready

    with stack.client(timeout_s=60) as c:
        tid = start_when_ready(c, {"subject_id": "BENCHCAM"}, ready_timeout_s=60)
        counter.counting.set()
        t0 = time.monotonic()
        time.sleep(seconds)
        counter.counting.clear()
        window_s = time.monotonic() - t0
        c.post(f"/trials/{tid}/stop").raise_for_status()
        deadline = time.monotonic() + timeout_s
        trial = c.get(f"/trials/{tid}").json()
        while trial["state"] not in FINISHED and time.monotonic() < deadline:
            time.sleep(0.5)
            trial = c.get(f"/trials/{tid}").json()
    return trial, window_s


def camera_rows(counter: ImageCounter, window_s: float, recorded: dict) -> list[dict]:
    rows = []
    for cam in sorted(counter.frame_ids):
        ids = np.unique(counter.frame_ids[cam])
        lag = np.asarray(counter.lag_ms[cam])
        rec = recorded.get(cam, {})
        rows.append({"camera": cam, "frames": int(ids.size), "fps": round(ids.size / window_s, 2),
                     "gaps": int(np.count_nonzero(np.diff(ids) > 1)),
                     "lag_ms_p50": round(float(np.percentile(lag, 50)), 1),
                     "lag_ms_p99": round(float(np.percentile(lag, 99)), 1),
                     "recorded_frames": rec.get("frames"), "recorded_missing": rec.get("missing_frames")})
    return rows


def _recording_path(catalog_url: str, trial_id: str) -> str:
    from gaitcap.services import catalog as cat

    db = cat.open_catalog(catalog_url)
    try:
        return cat.get_trial(db, trial_id).recording_path
    finally:
        db.close()


def run(*, seconds: float, cameras: int, size: str, camera_nodes: int, burn: int, timeout_s: float) -> dict:
    from gaitcap.acquisition.recording.reader import read_summary
    from gaitcap.services.bus.session import free_loopback_ports
    from gaitcap.services.ops.stack import Stack, StackConfig

    base = free_loopback_ports(24)[0]
    stop_burn = multiprocessing.Event()
    burners = [multiprocessing.Process(target=_burn, args=(stop_burn,), daemon=True) for _ in range(burn)]
    with tempfile.TemporaryDirectory(prefix="gaitcap-democams-") as tmp:
        cfg = StackConfig(data_dir=Path(tmp), token="demo-cameras-bench", port=base, bus_base_port=base + 1,
                          cameras=cameras, size=size, camera_nodes=camera_nodes)
        t0 = time.monotonic()
        with Stack(cfg) as stack:
            startup_s = time.monotonic() - t0
            for b in burners:
                b.start()
            counter = ImageCounter()
            session = stack.bus_session()
            try:
                sub = session.declare_subscriber(stack.bus.keys.image(), counter)
                trial, window_s = record_trial(stack, counter, seconds=seconds, timeout_s=timeout_s)
                sub.undeclare()
            finally:
                session.close()
                stop_burn.set()
                for b in burners:
                    b.join(10)
            recorded = read_summary(_recording_path(cfg.catalog, trial["id"])).get("cameras", {})
    rows = camera_rows(counter, window_s, recorded)
    fps = [r["fps"] for r in rows]
    return {"seconds": seconds, "cameras": cameras, "image_size": size, "camera_nodes": camera_nodes,
            "burn_processes": burn, "cpu_cores": os.cpu_count(), "load_avg_1min": round(os.getloadavg()[0], 2),
            "stack_startup_s": round(startup_s, 1), "window_s": round(window_s, 2), "per_camera": rows,
            "fps_min": min(fps, default=0.0), "fps_median": float(np.median(fps)) if fps else 0.0,
            "cameras_delivering": len(rows), "target_fps": TARGET_FPS,
            "target_met": len(rows) == cameras and min(fps, default=0.0) >= TARGET_FPS and trial["state"] == "done",
            "trial_state": trial["state"], "trial_warnings": list(trial.get("warnings") or ())}


def _table(r: dict) -> str:
    lines = [f"Demo cameras: {r['cameras']} simulated cameras ({r['image_size']} px) in {r['camera_nodes']} camera "
             f"process(es), {r['seconds']:g} s trial, {r['cpu_cores']} cores, {r['burn_processes']} busy process(es) "
             f"beside, load average {r['load_avg_1min']}",
             f"{'camera':<8} {'fps':>6} {'frames':>7} {'gaps':>5} {'lag p50 ms':>11} {'lag p99 ms':>11} "
             f"{'recorded':>9} {'rec. missing':>13}"]
    for c in r["per_camera"]:
        lines.append(f"{c['camera']:<8} {c['fps']:>6.2f} {c['frames']:>7} {c['gaps']:>5} {c['lag_ms_p50']:>11.1f} "
                     f"{c['lag_ms_p99']:>11.1f} {c['recorded_frames']!s:>9} {c['recorded_missing']!s:>13}")
    lines.append(f"fps min / median {r['fps_min']:.2f} / {r['fps_median']:.2f} (target >= {r['target_fps']:.0f} "
                 "and the trial done without warnings: "
                 f"{'met' if r['target_met'] else 'MISSED'})")
    lines.append(f"trial {r['trial_state']}" + "".join(f"\n  warning: {w}" for w in r["trial_warnings"]))
    lines.append("lag: camera node publish time minus the frame's own timestamp; shared machine, timings noisy")
    return "\n".join(lines)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seconds", type=float, default=20.0, help="trial length (s)")
    p.add_argument("--cameras", type=int, default=10)
    p.add_argument("--size", default="240x180", help="simulated image size (px)")
    p.add_argument("--camera-nodes", type=int, default=None, help="camera processes (default: the demo's)")
    p.add_argument("--burn", type=int, default=0, help="busy processes to run beside the stack (load)")
    p.add_argument("--timeout", type=float, default=300.0, help="after Stop, until the trial is finished (s)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    args = p.parse_args()
    logging.basicConfig(level=logging.WARNING)
    from gaitcap.services.ops.stack import StackConfig

    nodes = args.camera_nodes if args.camera_nodes is not None else StackConfig.camera_nodes
    result = run(seconds=args.seconds, cameras=args.cameras, size=args.size, camera_nodes=nodes, burn=args.burn,
                 timeout_s=args.timeout)
    emit(result, as_json=args.json, table=_table)


if __name__ == "__main__":
    main()
