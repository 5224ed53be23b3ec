"""Benchmark: the live path — 10 cameras x 30 fps x ~200 kB JPEG through Zenoh into an MCAP.

Three processes, as in the lab: a camera node (all cameras, one thread each), the recorder node
(``gaitcap node recorder``) and this controller (starts/stops the trial over the bus). Frames are
PRE-RENDERED: rendering and encoding 300 synthetic frames/s does not fit these 2 shared cores, so each
camera cycles through 64 random-noise JPEGs (~200 kB at 640x480) and every frame is made unique by an
8 kB random APP15 segment (so nothing repeats and compression figures stay honest).

Reports: frames published / recorded / in the MCAP (lost = published - in the file; target 0), bus
latency p50/p99 (camera node put -> recorder callback, same host clock; target p99 <= 20 ms), recorder
CPU (its process CPU time / trial time; target <= 50 % of one core), camera-node CPU, MCAP size and
write rate.

    python bench/live.py                    # 60 s, a table
    python bench/live.py --seconds 10 --json
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from gaitcap.services.bus.session import free_loopback_ports

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

PRERENDER_NOTE = ("frames pre-rendered: 64 random-noise JPEGs per camera (~200 kB, 640x480), each frame made "
                  "unique by an 8 kB random APP15 segment (rendering 300 frames/s does not fit 2 cores)")


# -- camera side (runs in its own process: --role cameras) --------------------------------------------
class NoiseJpegCamera:
    """A camera driver yielding pre-rendered, never-repeating JPEG frames at a fixed rate."""

    def __init__(self, name: str, pool: list[bytes], frames: int, fps: float, offset_ns: int) -> None:
        from gaitcap.acquisition.drivers.base import DriverStatus

        self.name, self.pool, self.n, self.period = name, pool, frames, int(round(1e9 / fps))
        self.offset_ns = offset_ns
        self._status = DriverStatus(camera=name)
        self._stop = False

    def start(self, at_ns=None):
        self.start_ns = time.time_ns() if at_ns is None else at_ns
        self._status.state, self._status.started_wall_s = "running", self.start_ns / 1e9

    def frames(self):
        from gaitcap.acquisition.drivers.base import Frame, wait_until_ns

        for i in range(self.n):
            if self._stop:
                break
            ts = self.start_ns + i * self.period + self.offset_ns
            wait_until_ns(ts)
            base = self.pool[i % len(self.pool)]
            app = os.urandom(8192)
            jpeg = base[:2] + b"\xff\xef" + struct.pack(">H", len(app) + 2) + app + base[2:]
            frame = Frame(camera=self.name, image=None, timestamp_ns=ts, frame_id=i, jpeg=jpeg)
            self._status.count(frame)
            yield frame
        self._status.state = "stopped"

    def stop(self):
        self._stop = True

    def status(self):
        return self._status


def _pool(seed: int, n: int = 64) -> list[bytes]:
    import cv2
    import numpy as np

    rng = np.random.default_rng(seed)
    canvas = cv2.GaussianBlur(rng.integers(0, 255, (480 + 64, 640 + 64, 3), dtype=np.uint8), (3, 3), 0)
    out = []
    for _ in range(n):
        y, x = rng.integers(0, 64, 2)
        crop = np.ascontiguousarray(canvas[y : y + 480, x : x + 640])
        out.append(cv2.imencode(".jpg", crop, [cv2.IMWRITE_JPEG_QUALITY, 93])[1].tobytes())
    return out


def run_cameras(args) -> None:
    from gaitcap.services.bus.session import load_bus_config, open_session
    from gaitcap.services.nodes.camera import CameraNode

    bus = load_bus_config(args.bus)
    drivers = [NoiseJpegCamera(f"cam{i + 1:02d}", _pool(i), int(args.seconds * args.fps), args.fps, i * 20_000)
               for i in range(args.cameras)]
    session = open_session(bus, "camera-0")
    node = CameraNode(session, bus, "camera-0", drivers)
    time.sleep(1.0)  # let the recorder's subscriptions arrive
    cpu0, t0 = time.process_time(), time.time()
    published = node.run(start_at_ns=time.time_ns() + 500_000_000)
    cpu = time.process_time() - cpu0
    node.close()
    session.close()
    print(json.dumps({"published": published, "cpu_percent": 100 * cpu / (time.time() - t0)}))


# -- controller -----------------------------------------------------------------------------------------

def run(*, seconds: float, cameras: int, fps: float, compression: str, out_dir: Path) -> dict:
    from gaitcap.acquisition.recording import layout
    from gaitcap.services.bus.control import RecorderClient
    from gaitcap.services.bus.session import BusConfig, alive_nodes, open_session
    from mcap.reader import make_reader

    names = ["recorder", "camera-0", "bench"]
    bus = BusConfig({n: f"tcp/127.0.0.1:{p}" for n, p in zip(names, free_loopback_ports(3), strict=True)},
                    prefix="gaitcap/bench")
    bus_file = out_dir / "bus.json"
    bus_file.write_text(json.dumps(bus.to_dict()))
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    rec = subprocess.Popen([sys.executable, "-c", "from gaitcap.services.cli import main; main()", "node", "recorder",
                            "--node", "recorder", "--bus", str(bus_file), "--compression", compression,
                            "--data-dir", str(out_dir)],
                           env=env, cwd=str(ROOT), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    session = open_session(bus, "bench")
    try:
        deadline = time.monotonic() + 60
        while "recorder" not in alive_nodes(session, bus):
            if time.monotonic() > deadline or rec.poll() is not None:
                raise RuntimeError("recorder node did not come up")
            time.sleep(0.2)
        client = RecorderClient(session, bus.keys, timeout_s=120)
        path = out_dir / "live.mcap"
        client.start(trial_id="bench", path=str(path), metadata={"bench": "live"})
        cam = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--role", "cameras", "--bus",
                              str(bus_file), "--seconds", str(seconds), "--cameras", str(cameras), "--fps", str(fps)],
                             env=env, cwd=str(ROOT), capture_output=True, text=True, timeout=seconds + 120)
        if cam.returncode != 0:
            raise RuntimeError(f"camera node failed: {cam.stderr[-2000:]}")
        cam_out = json.loads(cam.stdout.strip().splitlines()[-1])
        deadline = time.monotonic() + 60
        while client.status().queued and time.monotonic() < deadline:
            time.sleep(0.1)
        time.sleep(0.5)
        summary = client.stop("bench").summary
    finally:
        session.close()
        rec.send_signal(signal.SIGTERM)
        rec.wait(timeout=30)
    with open(path, "rb") as f:
        mc = make_reader(f).get_summary()
    in_file = sum(n for cid, n in mc.statistics.channel_message_counts.items()
                  if layout.is_image_topic(mc.channels[cid].topic))
    published = sum(cam_out["published"].values())
    size_mb = path.stat().st_size / 1e6
    mb_per_s = size_mb / max(summary["active_s"], 1e-9)  # over the seconds frames flowed, not the requested ones
    return {
        "seconds": seconds, "cameras": cameras, "fps": fps, "compression": compression,
        "frames_published": published, "frames_recorded": summary["frames"], "frames_in_mcap": in_file,
        "frames_lost": published - in_file, "missing_frame_ids": summary["missing_frames"],
        "latency_ms_p50": summary["latency_ms_p50"], "latency_ms_p99": summary["latency_ms_p99"],
        "recorder_cpu_percent": summary["active_cpu_percent"],
        "recorder_cpu_percent_whole_trial": summary["cpu_percent"], "camera_node_cpu_percent": cam_out["cpu_percent"],
        "mcap_mb": size_mb, "mcap_mb_per_s": mb_per_s, "mcap_gb_per_minute": mb_per_s * 60.0 / 1e3,
        "mean_frame_kb": size_mb * 1e3 / max(in_file, 1),
        "targets_met": {"frames_lost_0": published - in_file == 0,
                        "latency_p99_le_20ms": summary["latency_ms_p99"] is not None and summary["latency_ms_p99"] <= 20,
                        "recorder_cpu_le_50pct": summary["active_cpu_percent"] <= 50},
        "note": PRERENDER_NOTE,
    }


def _table(r: dict) -> str:
    rows = [
        ("trial", f"{r['cameras']} cameras x {r['fps']:g} fps x {r['seconds']:g} s, MCAP compression {r['compression']}"),
        ("frames published / recorded / in MCAP", f"{r['frames_published']} / {r['frames_recorded']} / {r['frames_in_mcap']}"),
        ("frames lost (target 0)", f"{r['frames_lost']}"),
        ("bus latency p50 / p99 (target p99 <= 20 ms)", f"{r['latency_ms_p50']:.2f} / {r['latency_ms_p99']:.2f} ms"),
        ("recorder CPU while frames flow (target <= 50 %)", f"{r['recorder_cpu_percent']:.1f} % of a core "
         f"({r['recorder_cpu_percent_whole_trial']:.1f} % over the whole trial)"),
        ("camera node CPU", f"{r['camera_node_cpu_percent']:.1f} %"),
        ("MCAP", f"{r['mcap_mb']:.0f} MB, {r['mcap_mb_per_s']:.1f} MB/s, {r['mean_frame_kb']:.0f} kB/frame, "
                 f"{r['mcap_gb_per_minute']:.2f} GB of disk per minute of recording"),
        ("targets met", ", ".join(f"{k}={v}" for k, v in r["targets_met"].items())),
    ]
    w = max(len(k) for k, _ in rows)
    lines = [f"{k.ljust(w)}  {v}" for k, v in rows]
    return "\n".join(lines + ["", f"note: {r['note']}", "timings on a shared 2-core machine are noisy"])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seconds", type=float, default=60.0)
    p.add_argument("--cameras", type=int, default=10)
    p.add_argument("--fps", type=float, default=30.0)
    p.add_argument("--compression", choices=["none", "lz4"], default="lz4")
    p.add_argument("--out", type=Path, default=None, help="Folder for the MCAP (default: a temp folder, removed).")
    p.add_argument("--json", action="store_true", help="Print one JSON object.")
    p.add_argument("--role", choices=["controller", "cameras"], default="controller", help=argparse.SUPPRESS)
    p.add_argument("--bus", type=Path, help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.role == "cameras":
        run_cameras(args)
        return
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        result = run(seconds=args.seconds, cameras=args.cameras, fps=args.fps, compression=args.compression,
                     out_dir=args.out)
    else:
        with tempfile.TemporaryDirectory() as tmp:
            result = run(seconds=args.seconds, cameras=args.cameras, fps=args.fps, compression=args.compression,
                         out_dir=Path(tmp))
    print(json.dumps(result) if args.json else _table(result))


if __name__ == "__main__":
    threading.current_thread().name = "bench-live"
    main()
