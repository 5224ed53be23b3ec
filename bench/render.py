"""Benchmark: rendering synthetic camera frames and JPEG-encoding them (the simulated camera driver's work).

Renders frames of a synthetic trial (room background, shaded people) from several rig cameras at the
chosen size and encodes each with ``cv2.imencode`` (JPEG quality 90); reports frames/s for rendering
alone, encoding alone and both, on one core of this machine, and how that compares with 10 cameras at
30 fps.

    python bench/render.py                    # a table
    python bench/render.py --json             # one JSON object on stdout
    python bench/render.py --size 1280x800 --people 3
"""

from __future__ import annotations

import argparse
import json
import time


def run(*, frames: int, width: int, height: int, people: int, cameras: int, quality: int, seed: int) -> dict:
    import cv2
    from gaitcap.simulator import make_trial
    from gaitcap.simulator.render import render_frame

    trial = make_trial(preset="clean", seconds=max(6.0, frames / 30.0 + 1.0), cameras=cameras, people=people, seed=seed)
    size = (width, height)
    n_frames = trial.times_s.shape[0]
    jobs = [(i % cameras, (i * 7) % n_frames) for i in range(frames)]
    t0 = time.perf_counter()
    for c in range(cameras):  # warm the per-camera background cache (a one-off per camera and size)
        render_frame(trial, c, 0, size)
    warm_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    images = [render_frame(trial, c, f, size) for c, f in jobs]
    render_s = time.perf_counter() - t0
    params = [int(cv2.IMWRITE_JPEG_QUALITY), quality]
    t0 = time.perf_counter()
    sizes = [len(cv2.imencode(".jpg", img, params)[1]) for img in images]
    encode_s = time.perf_counter() - t0
    total = render_s + encode_s
    return {
        "frames": frames, "size": f"{width}x{height}", "people": people, "cameras": cameras, "quality": quality,
        "background_warmup_s": warm_s,
        "render_fps": frames / render_s, "encode_fps": frames / encode_s, "render_encode_fps": frames / total,
        "render_ms": 1000 * render_s / frames, "encode_ms": 1000 * encode_s / frames,
        "jpeg_kb": sum(sizes) / len(sizes) / 1024, "realtime_cores_10x30fps": 300.0 / (frames / total),
    }


def _table(r: dict) -> str:
    rows = [
        ("frames", f"{r['frames']} at {r['size']}, {r['people']} people, {r['cameras']} cameras"),
        ("background (first frame per camera)", f"{r['background_warmup_s']:.2f} s for {r['cameras']} cameras"),
        ("render", f"{r['render_fps']:.0f} frames/s ({r['render_ms']:.2f} ms/frame)"),
        ("JPEG encode (quality {})".format(r["quality"]), f"{r['encode_fps']:.0f} frames/s ({r['encode_ms']:.2f} ms/frame)"),
        ("render + encode", f"{r['render_encode_fps']:.0f} frames/s"),
        ("mean JPEG size", f"{r['jpeg_kb']:.1f} kB"),
        ("cores for 10 cameras x 30 fps", f"{r['realtime_cores_10x30fps']:.2f}"),
    ]
    width = max(len(k) for k, _ in rows)
    return "\n".join(f"{k:<{width}}  {v}" for k, v in rows)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=300)
    ap.add_argument("--size", default="640x480", help="WIDTHxHEIGHT")
    ap.add_argument("--people", type=int, default=1)
    ap.add_argument("--cameras", type=int, default=10)
    ap.add_argument("--quality", type=int, default=90)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    try:
        w, h = (int(v) for v in args.size.lower().split("x"))
    except ValueError:
        ap.error(f"--size must be WIDTHxHEIGHT, got {args.size!r}")
    result = run(frames=args.frames, width=w, height=h, people=args.people, cameras=args.cameras,
                 quality=args.quality, seed=args.seed)
    print(json.dumps(result) if args.json else _table(result))


if __name__ == "__main__":
    main()
