"""Benchmark: N fake GigE Vision cameras streaming to camera nodes over the real protocol.

Starts N ``arv-fake-gv-camera-0.8`` processes (Debian aravis-tools; GVCP and GVSP over UDP) in a network
namespace of their own (one camera: on the host's 127.0.0.1 when namespaces cannot be made), one
``gaitcap node camera --source aravis`` per camera (512 x 512 BayerRG8, demosaiced and JPEG-encoded, on a
Zenoh bus inside the namespace) and a probe on the bus. Prints per camera: frames/s received on the bus,
incomplete frames, lost frames (frame-id gaps), resend requests, CPU of its camera node process (and of
the fake camera), and latency from the device timestamp to the bus (p50 / p95, ms). ``--lossy-link``
makes camera 1 lose 2 in 1000 GVSP packets and passes its stream through ``tc`` (netem 0.1 % loss and
20 ms delay where the kernel has it, else a 100 Mbit/s rate limit whose queue delays it) to show the
faults counted. Target: 4 cameras at 30 fps with 0 incomplete frames.

    python bench/gige.py                          # table, 4 cameras, 10 s
    python bench/gige.py --cameras 2 --seconds 5 --json
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from _common import emit  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PY_CLI = [sys.executable, "-c", "from gaitcap.services.cli import main; main()"]
TARGET_CAMERAS, TARGET_FPS = 4, 30.0
LOSSY_PER_THOUSAND = 2  # --lossy-link: GVSP packets camera 1 never sends (random loss on its link)
LEAD_S = 10.0  # camera nodes start streaming this long after launch (imports, opening the cameras)


def _cpu_s(pid: int) -> float:
    """User + system CPU seconds of process ``pid`` (0 when it is gone)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def probe(bus_file: str, out: str, cameras: list[str], seconds: float) -> None:
    """Inside the namespace: receive frames and status on the bus for ``seconds``; write a JSON summary."""
    import numpy as np
    from gaitcap.services.bus.messages import CameraStatus, ImageFrame
    from gaitcap.services.bus.session import load_bus_config, open_session

    bus = load_bus_config(bus_file)
    session = open_session(bus, None)
    lat = {c: [] for c in cameras}
    first, last, status, errors = {}, {}, {}, {}

    def on_image(sample) -> None:
        now = time.time_ns()
        cam = str(sample.key_expr).split("/")[-2]
        att = sample.attachment.to_bytes() if sample.attachment is not None else None
        try:
            frame = ImageFrame.from_bytes(sample.payload.to_bytes(), att, camera=cam)
        except ValueError as exc:
            errors[cam] = errors.get(cam, 0) + 1
            logging.warning("probe: %s", exc)
            return
        lat[cam].append((now - frame.timestamp_ns) / 1e6)
        first.setdefault(cam, now)
        last[cam] = now

    def on_status(sample) -> None:
        payload = sample.payload.to_bytes()
        st = CameraStatus.from_bytes(payload)  # checked; kept as sent (driver counters under "extra")
        status[st.camera] = json.loads(payload)

    subs = [session.declare_subscriber(bus.keys.image(), on_image),
            session.declare_subscriber(bus.keys.status(), on_status)]
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and not stop.is_set():
        if len(status) == len(cameras) and all(s["state"] in ("stopped", "error") for s in status.values()):
            break
        time.sleep(0.2)
    for s in subs:
        s.undeclare()
    session.close()
    report = {}
    for cam in cameras:
        got = np.asarray(lat[cam]) if lat[cam] else np.zeros(0)
        span_s = (last[cam] - first[cam]) / 1e9 if len(got) > 1 else 0.0
        report[cam] = {"received": int(got.size), "fps": round((got.size - 1) / span_s, 2) if span_s else 0.0,
                       "latency_ms_p50": round(float(np.percentile(got, 50)), 2) if got.size else None,
                       "latency_ms_p95": round(float(np.percentile(got, 95)), 2) if got.size else None,
                       "unreadable": errors.get(cam, 0), "status": status.get(cam)}
    Path(out).write_text(json.dumps(report))


def _bus_file(tmp: Path, n: int) -> Path:
    path = tmp / "bus.json5"
    nodes = {f"camera-{i}": f"tcp/127.0.0.1:{17450 + i}" for i in range(n)}
    path.write_text(json.dumps({"prefix": "gaitcap/gige-bench", "lease_ms": 3000, "insecure_plain": True,
                                "nodes": nodes}))
    return path


def run(cameras: int, seconds: float, fps: float, packet_size: int, lossy_link: bool) -> dict:
    from gaitcap.simulator.fake_gige import FakeGigELab, namespace_unavailable

    no_ns = namespace_unavailable()
    if no_ns and (cameras > 1 or lossy_link):
        raise SystemExit(f"bench/gige.py: {cameras} cameras or --lossy-link need a network namespace: {no_ns}")
    names = [f"cam{i + 1:02d}" for i in range(cameras)]
    frames = int(round(seconds * fps))
    lost = [LOSSY_PER_THOUSAND if lossy_link and i == 0 else 0 for i in range(cameras)]
    with tempfile.TemporaryDirectory() as tmp_name, FakeGigELab(cameras, namespace=not no_ns,
                                                                lost_per_thousand=lost) as lab:
        tmp = Path(tmp_name)
        link = "clean"
        if lossy_link:
            link = (f"{LOSSY_PER_THOUSAND} per 1000 GVSP packets lost; "
                    + lab.shape(source=lab.addresses[0], loss_percent=0.1, delay_ms=20.0, rate_mbit=100.0,
                                queue_packets=64))
        bus = _bus_file(tmp, cameras)
        env = dict(os.environ, GAITCAP_BUS=str(bus), PYTHONPATH=str(ROOT))
        start_ns = time.time_ns() + int(LEAD_S * 1e9)
        out = tmp / "probe.json"
        nodes = [subprocess.Popen([*lab.exec_prefix, *PY_CLI, "node", "camera", "--node", f"camera-{i}",
                                   "--source", "aravis", "--devices", addr, "--cameras", name, "--fps", str(fps),
                                   "--exposure-us", "8000", "--pixel-format", "BayerRG8", "--packet-size",
                                   str(packet_size), "--frames", str(frames), "--start-at-ns", str(start_ns)],
                                  env=env, stdout=subprocess.DEVNULL, stderr=(tmp / f"{name}.log").open("wb"))
                 for i, (addr, name) in enumerate(zip(lab.addresses, names, strict=True))]
        time.sleep(2.0)  # the probe connects to camera nodes that already listen
        probe_proc = subprocess.Popen([*lab.exec_prefix, sys.executable, __file__, "--probe", str(bus), str(out),
                                       ",".join(names), str(LEAD_S + seconds + 180)], env=env)
        cpu = _measure_cpu(nodes, lab, start_ns, seconds)
        exits = [node.wait(timeout=seconds + 120) for node in nodes]
        for name, code in zip(names, exits, strict=True):
            if code != 0:
                logging.warning("camera node of %s exited %s: %s", name, code,
                                (tmp / f"{name}.log").read_text(errors="replace")[-1500:])
        time.sleep(2.0)  # the last status messages
        probe_proc.terminate()
        probe_proc.wait(timeout=30)
        per_camera = json.loads(out.read_text())
    for name, (node_cpu, fake_cpu), code in zip(names, cpu, exits, strict=True):
        per_camera[name].update(node_cpu_percent=node_cpu, fake_camera_cpu_percent=fake_cpu, node_exit=code)
    return {"cameras": cameras, "seconds": seconds, "fps_set": fps, "packet_size_bytes": packet_size,
            "size_px": [512, 512], "pixel_format": "BayerRG8", "link_camera_1": link,
            "namespace": not no_ns, "per_camera": per_camera}


def _measure_cpu(nodes, lab, start_ns: int, seconds: float) -> list[tuple[float, float]]:
    """CPU % of each camera node and each fake camera over the middle of the stream."""
    time.sleep(max(0.0, (start_ns - time.time_ns()) / 1e9 + 1.0))
    pids = [(n.pid, c.process.pid) for n, c in zip(nodes, lab.cameras, strict=True)]
    t0, c0 = time.monotonic(), [(_cpu_s(a), _cpu_s(b)) for a, b in pids]
    time.sleep(max(1.0, seconds - 2.0))
    t1, c1 = time.monotonic(), [(_cpu_s(a), _cpu_s(b)) for a, b in pids]
    return [(round(100 * (a1 - a0) / (t1 - t0), 1), round(100 * (b1 - b0) / (t1 - t0), 1))
            for (a0, b0), (a1, b1) in zip(c0, c1, strict=True)]


def table(report: dict) -> str:
    head = (f"{'camera':8s} {'fps':>6s} {'bus/sent':>12s} {'incompl':>7s} {'lost':>5s} {'resend':>6s} {'skip':>4s} "
            f"{'node CPU%':>9s} {'fake CPU%':>9s} {'lat p50 ms':>10s} {'lat p95 ms':>10s}")
    rows = []
    for cam, r in report["per_camera"].items():
        st = r["status"] or {}
        ex = st.get("extra", {})
        rows.append(f"{cam:8s} {r['fps']:6.2f} {r['received']:6d}/{st.get('published', 0):<5d} {ex.get('incomplete', -1):7d} {st.get('drops', -1):5d} "
                    f"{ex.get('resend_requests', -1):6d} {ex.get('device_skipped', -1):4d} {r['node_cpu_percent']:9.1f} "
                    f"{r['fake_camera_cpu_percent']:9.1f} {r['latency_ms_p50'] or float('nan'):10.2f} "
                    f"{r['latency_ms_p95'] or float('nan'):10.2f}")
    incomplete = sum((r["status"] or {}).get("extra", {}).get("incomplete", 0) for r in report["per_camera"].values())
    foot = (f"\n{report['cameras']} fake GigE Vision cameras, {report['size_px'][0]}x{report['size_px'][1]} "
            f"{report['pixel_format']} at {report['fps_set']:g} fps, packets {report['packet_size_bytes']} B, "
            f"camera 1 link: {report['link_camera_1']}; {incomplete} incomplete frames "
            f"(target: {TARGET_CAMERAS} cameras at {TARGET_FPS:g} fps, 0 incomplete, on a clean link)")
    return "\n".join([head, "-" * len(head), *rows]) + foot


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--probe":
        bus_file, out, cams, seconds = sys.argv[2:6]
        probe(bus_file, out, cams.split(","), float(seconds))
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cameras", type=int, default=TARGET_CAMERAS)
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--fps", type=float, default=TARGET_FPS)
    parser.add_argument("--packet-size", type=int, default=9000, help="GVSP packet size, bytes")
    parser.add_argument("--lossy-link", action="store_true", help="camera 1's stream through tc loss/delay")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING, stream=sys.stderr)
    report = run(args.cameras, args.seconds, args.fps, args.packet_size, args.lossy_link)
    emit(report, as_json=args.json, table=table)


if __name__ == "__main__":
    main()
