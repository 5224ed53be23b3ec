"""What counting a recording's images from the file costs (a trial recovered after a crash has no
recorder summary): the images' timestamps from the MCAP message index, against the summary read and a
read of every image message (what a file without an index costs).

    python bench/image_index.py [--cameras 10] [--seconds 60] [--jpeg-kb 60] [--json]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np
from _common import emit
from gaitcap.acquisition.encoding import image_message
from gaitcap.acquisition.recording import layout
from gaitcap.acquisition.recording.reader import iter_messages, read_image_times, read_summary
from gaitcap.acquisition.recording.writer import TrialWriter

FPS = 30


def _write(path: Path, *, cameras: int, seconds: float, jpeg_bytes: int) -> None:
    rng = np.random.default_rng(0)
    jpegs = [rng.integers(0, 256, jpeg_bytes, dtype=np.uint8).tobytes() for _ in range(8)]  # JPEG barely compresses
    writer = TrialWriter(path)
    t0 = 1_700_000_000_000_000_000
    writer.start(metadata={"trial_id": "bench"}, time_ns=t0)
    names = [f"cam{c}" for c in range(cameras)]
    for fid in range(int(seconds * FPS)):
        ts = t0 + fid * 1_000_000_000 // FPS
        for c, name in enumerate(names):
            writer.add_frame(name, image_message(jpegs[(fid + c) % 8], camera=name, timestamp_ns=ts),
                             timestamp_ns=ts, frame_id=fid, receive_ns=ts)
    writer.finish({"cameras": {}})


def run(*, cameras: int, seconds: float, jpeg_kb: int) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "trial.mcap"
        _write(path, cameras=cameras, seconds=seconds, jpeg_bytes=jpeg_kb * 1024)
        size_mb = os.path.getsize(path) / 1e6
        t = time.perf_counter()
        read_summary(path)
        summary_s = time.perf_counter() - t
        t = time.perf_counter()
        times = read_image_times(path)
        index_s = time.perf_counter() - t
        t = time.perf_counter()
        every = sum(1 for _ in iter_messages(path, layout.is_image_topic))
        messages_s = time.perf_counter() - t
    images = sum(t.size for t in times.values())
    if images != every:
        raise RuntimeError(f"the message index counts {images} images, the messages {every}")
    return {"cameras": cameras, "seconds": seconds, "file_mb": round(size_mb, 1), "images": images,
            "summary_s": round(summary_s, 4), "image_index_s": round(index_s, 4),
            "image_messages_s": round(messages_s, 3)}


def _table(r: dict) -> str:
    return "\n".join([
        f"recording: {r['cameras']} cameras x {r['seconds']:.0f} s, {r['images']} images, {r['file_mb']} MB",
        f"{'read':<36}{'time (s)':>10}",
        f"{'recorder summary (metadata record)':<36}{r['summary_s']:>10.4f}",
        f"{'image timestamps (message index)':<36}{r['image_index_s']:>10.4f}",
        f"{'every image message (no index)':<36}{r['image_messages_s']:>10.3f}",
    ])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cameras", type=int, default=10)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--jpeg-kb", type=int, default=60)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    emit(run(cameras=a.cameras, seconds=a.seconds, jpeg_kb=a.jpeg_kb), as_json=a.json, table=_table)


if __name__ == "__main__":
    main()
