"""Benchmark: 2D detector speed at 640x480 on a real walking video.

Frames of the sports2d demo video (installed by deploy/bootstrap.sh), centre-cropped to 4:3 and resized
to 640x480, go through MediaPipe Pose (lite / full / heavy) in tracking mode (one pose, one camera,
consecutive frames: the person detector runs only when the pose is lost), in image mode (one pose,
detector + landmarks on every frame), with the default options (everyone: up to 4 poses, each tracked,
the person detector every 5th frame for newcomers while someone is tracked) and with the person detector
on every frame (``search_every=1``, MediaPipe's own way), and through the ONNX detector's pre/post-processing with a trivial model (the crop, the
normalisation and onnxruntime's call overhead, not a real network). Wall time and CPU time per frame.

    python bench/detectors.py                # a table
    python bench/detectors.py --json         # one JSON object on stdout
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
from gaitcap.acquisition.installed import share_path

VIDEO = share_path("testdata", "sports2d-demo.mp4")
SIZE = (640, 480)


def load_frames(count: int, first: int = 60) -> list[np.ndarray]:
    if not VIDEO.is_file():
        raise FileNotFoundError(f"{VIDEO} missing: run deploy/bootstrap.sh")
    cap = cv2.VideoCapture(str(VIDEO))
    cap.set(cv2.CAP_PROP_POS_FRAMES, first)
    frames = []
    while len(frames) < count:
        ok, frame = cap.read()
        if not ok:
            break
        h, w = frame.shape[:2]
        cw = h * 4 // 3
        x0 = (w - cw) * 3 // 4  # the walker is right of centre in these frames
        frames.append(cv2.resize(frame[:, x0 : x0 + cw], SIZE, interpolation=cv2.INTER_AREA))
    cap.release()
    return frames


def time_detector(detector, frames: list[np.ndarray], *, consecutive: bool) -> dict:
    detector.detect(frames[0], camera="warm-up", frame_id=0, timestamp_ns=0)
    found = 0
    t0, c0 = time.perf_counter(), time.process_time()
    for i, frame in enumerate(frames):
        fid = i if consecutive else 2 * i  # gaps stop tracking
        found += detector.detect(frame, camera="cam", frame_id=fid, timestamp_ns=0).shape[0] > 0
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    n = len(frames)
    return {"ms_per_frame": 1e3 * wall / n, "cpu_ms_per_frame": 1e3 * cpu / n, "found_fraction": found / n}


def trivial_onnx(path: Path) -> Path:
    import onnx
    from onnx import TensorProto, helper

    h, w, j = 256, 192, 26
    nodes = [
        helper.make_node("ReduceMean", ["input", "ax"], ["m"], keepdims=0),  # (N,)
        helper.make_node("Reshape", ["m", "sh"], ["m3"]),  # (N, 1, 1)
        helper.make_node("Expand", ["m3", "ex"], ["simcc_x"]),
        helper.make_node("Expand", ["m3", "ey"], ["simcc_y"]),
    ]
    i64 = lambda n, v: helper.make_tensor(n, TensorProto.INT64, [len(v)], v)  # noqa: E731
    graph = helper.make_graph(
        nodes, "trivial", [helper.make_tensor_value_info("input", TensorProto.FLOAT, ["N", 3, h, w])],
        [helper.make_tensor_value_info("simcc_x", TensorProto.FLOAT, ["N", j, 2 * w]),
         helper.make_tensor_value_info("simcc_y", TensorProto.FLOAT, ["N", j, 2 * h])],
        initializer=[i64("ax", [1, 2, 3]), i64("sh", [-1, 1, 1]), i64("ex", [1, j, 2 * w]), i64("ey", [1, j, 2 * h])],
    )
    onnx.save(helper.make_model(graph, opset_imports=[helper.make_opsetid("", 18)], ir_version=9), str(path))
    return path


def run(*, frames: int, threads: int) -> dict:
    from gaitcap.acquisition.detectors.mediapipe import MediaPipeConfig
    from gaitcap.acquisition.detectors.onnx import OnnxConfig

    imgs = load_frames(frames)
    rows = []
    poses, every = MediaPipeConfig.num_poses, MediaPipeConfig.search_every
    modes = (("tracking", True, 1, every), ("image", False, 1, every), ("everyone (default)", True, poses, every),
             ("everyone, search every frame", True, poses, 1))
    for model in ("lite", "full", "heavy"):
        for mode, consecutive, num_poses, search_every in modes:
            det = MediaPipeConfig(model=model, num_threads=threads, num_poses=num_poses,
                                  search_every=search_every).build()
            res = time_detector(det, imgs, consecutive=consecutive)
            rows.append({"detector": f"mediapipe-{model}", "mode": mode, **res})
    with tempfile.TemporaryDirectory() as tmp:
        det = OnnxConfig(model_path=trivial_onnx(Path(tmp) / "t.onnx"), num_threads=threads).build()
        res = time_detector(det, imgs, consecutive=True)
        rows.append({"detector": "onnx-overhead (trivial model, 256x192)", "mode": "whole image", **res})
    return {
        "benchmark": "detectors",
        "image_size_px": list(SIZE),
        "frames": len(imgs),
        "threads": threads,
        "cpu_count": os.cpu_count(),
        "note": "shared 2-core machine: timings are noisy",
        "rows": rows,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    result = run(frames=args.frames, threads=args.threads)
    if args.json:
        print(json.dumps(result))
        return
    print(f"2D detectors at {SIZE[0]}x{SIZE[1]}, {result['frames']} frames of the sports2d demo, "
          f"{args.threads} threads ({result['note']})")
    print(f"{'detector':42s} {'mode':29s} {'ms/frame':>9s} {'cpu ms':>8s} {'found':>6s}")
    for r in result["rows"]:
        print(f"{r['detector']:42s} {r['mode']:29s} {r['ms_per_frame']:9.1f} {r['cpu_ms_per_frame']:8.1f} "
              f"{100 * r['found_fraction']:5.0f}%")


if __name__ == "__main__":
    main()
