"""Benchmark: what the bus security and the typed messages cost.

1. Parsing: ``Keypoints.from_bytes`` (one person, halpe26, bounds on every coordinate) and
   ``ImageFrame.from_bytes`` (a 200 kB JPEG frame) against a bare ``json.loads`` / protobuf parse, in
   microseconds per message; x 300 messages/s (10 cameras x 30 fps) gives the share of a core.
2. The bus: a publisher and a subscriber session (this process, loopback) on a plain TCP bus and on a
   secured bus (mutual TLS, user/password, access control by role): frames/s and MB/s of 200 kB frames
   put as fast as the bus takes them (congestion control BLOCK), and the round trip of a small query
   (p50 / p99, ms). Target: the secured bus carries >= 300 frames/s (10 cameras x 30 fps) of 200 kB.

    python bench/bus_security.py                 # a table
    python bench/bus_security.py --seconds 2 --json
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
from gaitcap.services.bus.session import free_loopback_ports

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench._common import emit  # noqa: E402

JPEG_BYTES = 200_000
TARGET_FPS = 300.0


def _per_message_us(fn, n: int) -> float:
    t0 = time.perf_counter()
    for _ in range(n):
        fn()
    return (time.perf_counter() - t0) / n * 1e6


def parsing(n: int = 3000) -> dict:
    from gaitcap.acquisition.encoding import parse_image_message
    from gaitcap.services.bus.messages import ImageFrame, Keypoints

    rng = np.random.default_rng(0)
    people = np.round(np.c_[rng.uniform(0, 1920, (26, 2)), rng.uniform(0, 1, (26, 1))], 4)[None].tolist()
    kp = Keypoints("cam01", 1234, 10**18, "halpe26", people, 3.2).to_bytes()
    jpeg = b"\xff\xd8" + rng.integers(0, 255, JPEG_BYTES, dtype=np.uint8).tobytes() + b"\xff\xd9"
    frame = ImageFrame.build(jpeg, camera="cam01", timestamp_ns=10**18, frame_id=1234, sent_ns=10**18)
    att = frame.meta.to_bytes()
    out = {
        "keypoints_typed_us": _per_message_us(lambda: Keypoints.from_bytes(kp), n),
        "keypoints_json_us": _per_message_us(lambda: json.loads(kp), n),
        "frame_typed_us": _per_message_us(lambda: ImageFrame.from_bytes(frame.payload, att, camera="cam01"), n),
        "frame_protobuf_json_us": _per_message_us(lambda: (parse_image_message(frame.payload), json.loads(att)), n),
    }
    extra_us = out["keypoints_typed_us"] - out["keypoints_json_us"] + out["frame_typed_us"] - out["frame_protobuf_json_us"]
    out["extra_core_percent_at_300_per_s"] = extra_us * TARGET_FPS / 1e6 * 100
    return out



def _bus(secure: bool, keys: Path):
    from gaitcap.services.bus.certs import make_bus_keys
    from gaitcap.services.bus.security import BusSecurity
    from gaitcap.services.bus.session import BusConfig

    proto = "tls" if secure else "tcp"
    nodes = {n: f"{proto}/127.0.0.1:{p}" for n, p in zip(("recorder", "camera-0"), free_loopback_ports(2), strict=True)}
    security = BusSecurity(keys) if secure else None
    bus = BusConfig(nodes, prefix="gaitcap/bench", security=security)
    if secure:
        make_bus_keys(dict(nodes), keys)
    return bus


def bus_run(secure: bool, seconds: float, keys: Path) -> dict:
    import zenoh
    from gaitcap.services.bus.session import alive_nodes, declare_alive, open_session

    bus = _bus(secure, keys)
    rec, cam = open_session(bus, "recorder"), open_session(bus, "camera-0")
    got = [0, 0]
    lock = threading.Lock()

    def on_frame(sample) -> None:
        with lock:
            got[0] += 1
            got[1] += len(sample.payload)

    token = declare_alive(rec, bus, "recorder")
    sub = rec.declare_subscriber(bus.keys.image(), on_frame)
    queryable = rec.declare_queryable(bus.keys.recorder_status, lambda q: q.reply(q.key_expr, b'{"ok":true}'))
    try:
        deadline = time.monotonic() + 20
        while "recorder" not in alive_nodes(cam, bus) and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(0.5)
        pub = cam.declare_publisher(bus.keys.image("cam01"), congestion_control=zenoh.CongestionControl.BLOCK)
        payload = bytes(JPEG_BYTES)
        sent, t0 = 0, time.monotonic()
        while time.monotonic() - t0 < seconds:
            pub.put(payload)
            sent += 1
        time.sleep(0.3)
        elapsed = time.monotonic() - t0
        rtts = []
        for _ in range(200):
            q0 = time.perf_counter()
            list(cam.get(bus.keys.recorder_status, timeout=2.0))
            rtts.append((time.perf_counter() - q0) * 1e3)
        with lock:
            frames, nbytes = got
        return {"frames_sent": sent, "frames_received": frames, "frames_per_s": frames / elapsed,
                "mb_per_s": nbytes / elapsed / 1e6, "query_ms_p50": float(np.percentile(rtts, 50)),
                "query_ms_p99": float(np.percentile(rtts, 99))}
    finally:
        sub.undeclare()
        queryable.undeclare()
        token.undeclare()
        rec.close()
        cam.close()


def _table(result: dict) -> str:
    ps = result["parsing"]
    lines = ["parsing (us/message)        typed   bare",
             f"  keypoints (halpe26, 1p)  {ps['keypoints_typed_us']:6.1f} {ps['keypoints_json_us']:6.1f}",
             f"  frame (200 kB JPEG)      {ps['frame_typed_us']:6.1f} {ps['frame_protobuf_json_us']:6.1f}",
             f"  extra at 300 frames + 300 keypoints/s: {ps['extra_core_percent_at_300_per_s']:.2f} % of a core",
             "bus (200 kB frames, loopback)  frames/s    MB/s   query p50 ms  p99 ms"]
    for name in ("plain", "secured"):
        r = result[name]
        lines.append(f"  {name:8s}                   {r['frames_per_s']:8.0f} {r['mb_per_s']:7.0f}   "
                     f"{r['query_ms_p50']:10.2f}  {r['query_ms_p99']:6.2f}")
    lines.append(f"secured bus >= {TARGET_FPS:.0f} frames/s: {result['meets_target']}")
    return "\n".join(lines)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seconds", type=float, default=4.0, help="Seconds of frames per bus.")
    p.add_argument("--json", action="store_true", help="Print one JSON object.")
    args = p.parse_args()
    import logging

    logging.disable(logging.WARNING)  # the plain bus's start-up warning
    result = {"parsing": parsing()}
    with tempfile.TemporaryDirectory() as tmp:
        result["plain"] = bus_run(False, args.seconds, Path(tmp) / "keys")
        result["secured"] = bus_run(True, args.seconds, Path(tmp) / "keys")
    result["meets_target"] = result["secured"]["frames_per_s"] >= TARGET_FPS
    emit(result, as_json=args.json, table=_table)

if __name__ == "__main__":
    main()
