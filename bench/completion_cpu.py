"""Benchmark: where the CPU goes per frame when a trial's recorded images are detected after Stop.

Writes a trial MCAP of N cameras x S seconds of the sports2d walk (1768x994, JPEG quality 90 as the camera
node sends it; no live keypoints), then measures CPU time per frame (process CPU, not wall: the machine may
be shared) of each stage in this process, one camera's frames in order:

- ``read``: the MCAP's image messages read and parsed (``iter_frames``; the completion's parent process);
- ``transfer``: a frame task pickled and unpickled (what the pipe to a worker process costs, both ends);
- ``decode``: the JPEG decoded at full size, and (for comparison) at half size by libjpeg's DCT scaling;
- ``colour``: a BGR -> RGB conversion of the whole image (MediaPipe converts only its crops);
- ``models``: one run of the person detector and of the landmark model (1 thread);
- ``detect``: decode + MediaPipe, frames in order (tracking holds) and with every 10th frame left out (as
  when completing the frames between live ones: tracking restarts after each gap), with the share of
  frames the person detector ran on and the people found per frame;

then ``complete_keypoints`` end to end over W worker processes, MediaPipe with 1 and with 2 interpreter
threads per worker: the parent's CPU and the workers' CPU per frame (workers' start-up included) and wall.

    python bench/completion_cpu.py [--cameras 4] [--seconds 3] [--workers 2] [--model full] [--json]
"""

from __future__ import annotations

import argparse
import os
import pickle
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from bench._common import emit  # noqa: E402

T0_NS, PERIOD_NS = 1_700_000_000_000_000_000, 33_333_333


def write_trial(path: Path, *, cameras: int, frames: int) -> Path:
    """A trial MCAP: every camera records the video's first ``frames`` frames (JPEG quality 90)."""
    import cv2
    from gaitcap.acquisition.encoding import encode_jpeg, image_message
    from gaitcap.acquisition.installed import share_path
    from gaitcap.acquisition.recording.writer import TrialWriter

    cap = cv2.VideoCapture(str(share_path("testdata", "sports2d-demo.mp4")))
    jpegs = []
    while len(jpegs) < frames:
        ok, img = cap.read()
        if not ok:
            raise SystemExit("the sports2d video is missing or shorter than asked: run deploy/bootstrap.sh")
        jpegs.append(encode_jpeg(img, quality=90))
    cap.release()
    w = TrialWriter(path)
    w.start(metadata={"trial_id": "cpu"}, time_ns=T0_NS)
    for f, jpeg in enumerate(jpegs):
        ts = T0_NS + f * PERIOD_NS
        for c in range(cameras):
            cam = f"cam{c + 1:02d}"
            w.add_frame(cam, image_message(jpeg, camera=cam, timestamp_ns=ts), timestamp_ns=ts, frame_id=f, receive_ns=ts)
    return w.finish({})


def _cpu_ms(fn, items) -> float:
    """CPU ms per item of ``fn`` (results dropped at once, as a worker does)."""
    c = time.process_time()
    for x in items:
        fn(x)
    return 1e3 * (time.process_time() - c) / max(1, len(items))


def stages(path: Path, *, model: str) -> dict:
    """CPU ms per frame of each stage, in this process, over the first camera's frames."""
    import cv2
    from gaitcap.acquisition.detectors.mediapipe import MediaPipeConfig, _Tflite, model_files
    from gaitcap.acquisition.detectors.pool import FrameTask
    from gaitcap.acquisition.encoding import decode_jpeg
    from gaitcap.acquisition.recording.reader import iter_frames

    c = time.process_time()
    frames = list(iter_frames(path))
    read_ms = 1e3 * (time.process_time() - c) / len(frames)
    mine = [f for f in frames if f.camera == frames[0].camera]
    tasks = [FrameTask(f.camera, f.frame_id, f.timestamp_ns, 0, f.jpeg) for f in mine]
    image = decode_jpeg(mine[0].jpeg)
    out = {"image_px": [image.shape[1], image.shape[0]], "jpeg_kib": float(np.mean([len(f.jpeg) for f in mine]) / 1024),
           "read_ms": read_ms,
           "transfer_ms": _cpu_ms(lambda t: pickle.loads(pickle.dumps(t, protocol=pickle.HIGHEST_PROTOCOL)), tasks),
           "decode_full_ms": _cpu_ms(lambda f: decode_jpeg(f.jpeg), mine),
           "decode_half_ms": _cpu_ms(lambda f: cv2.imdecode(np.frombuffer(f.jpeg, np.uint8),
                                                            cv2.IMREAD_REDUCED_COLOR_2), mine),
           "colour_full_ms": _colour_ms(mine)}
    config = MediaPipeConfig(model=model, num_threads=1)
    for name, model_path, side in zip(("person_detector", "landmarks"), model_files(config), (224, 256), strict=True):
        net, x = _Tflite(model_path, 1), np.zeros((1, side, side, 3), np.float32)
        net.run(x)
        out[f"{name}_ms"] = _cpu_ms(lambda _, n=net, x=x: n.run(x), range(50))
    for order, keep in (("in_order", lambda i: True), ("gaps", lambda i: i % 10 != 0)):
        det = config.build()
        searches = _count_searches(det)
        todo = [f for i, f in enumerate(mine) if keep(i)]
        people = []
        ms = _cpu_ms(lambda f, d=det, p=people: p.append(len(d.detect(decode_jpeg(f.jpeg), camera=f.camera,
                                                                  frame_id=f.frame_id, timestamp_ns=f.timestamp_ns))),
                     todo)
        out[f"detect_{order}_ms"] = ms
        out[f"person_detector_share_{order}"] = searches[0] / max(1, len(todo))
        out[f"people_per_frame_{order}"] = float(np.mean(people))
    return out


def _colour_ms(frames) -> float:
    """CPU ms of a BGR -> RGB conversion of each whole decoded image (the decoding not counted)."""
    import cv2
    from gaitcap.acquisition.encoding import decode_jpeg

    spent = 0.0
    for f in frames:
        image = decode_jpeg(f.jpeg)
        c = time.process_time()
        cv2.cvtColor(image, cv2.COLOR_BGR2RGB)
        spent += time.process_time() - c
    return 1e3 * spent / max(1, len(frames))


def _count_searches(det) -> list[int]:
    """A counter of the person detector's runs on ``det`` (its ``find_people`` wrapped)."""
    count, find = [0], det.find_people

    def counted(rgb):
        count[0] += 1
        return find(rgb)

    det.find_people = counted
    return count


def end_to_end(path: Path, *, model: str, workers: int, threads: int) -> dict:
    """``complete_keypoints`` of every frame over ``workers`` processes: CPU ms per frame (parent, workers)."""
    from gaitcap.acquisition.detectors.mediapipe import MediaPipeConfig
    from gaitcap.services.processing.completion import complete_keypoints

    config = MediaPipeConfig(model=model, num_threads=threads)
    kids0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    c, w = time.process_time(), time.perf_counter()
    _, report = complete_keypoints(path, None, config.build, detector_name=f"mediapipe {model}", workers=workers)
    parent, wall = time.process_time() - c, time.perf_counter() - w
    kids1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    child = (kids1.ru_utime + kids1.ru_stime) - (kids0.ru_utime + kids0.ru_stime)
    n = sum(cam.completed for cam in report.cameras)
    return {"threads": threads, "frames": n, "wall_s": wall, "frames_per_s": n / wall,
            "parent_cpu_ms": 1e3 * parent / n, "workers_cpu_ms": 1e3 * child / n,
            "total_cpu_ms": 1e3 * (parent + child) / n}


def run(*, cameras: int, seconds: float, workers: int, model: str) -> dict:
    with tempfile.TemporaryDirectory(prefix="completion-cpu-") as tmp:
        path = write_trial(Path(tmp) / "trial.mcap", cameras=cameras, frames=round(seconds * 30))
        result = {"cameras": cameras, "seconds": seconds, "workers": workers, "model": model,
                  "cpus": os.cpu_count(), "load_average_before": os.getloadavg()[0], "stages": stages(path, model=model),
                  "end_to_end": [end_to_end(path, model=model, workers=workers, threads=n) for n in (1, 2)]}
    result["load_average_after"] = os.getloadavg()[0]
    return result


def table(r: dict) -> str:
    s = r["stages"]
    lines = [f"completion CPU per frame: {r['cameras']} cameras x {r['seconds']:g} s of the sports2d walk "
             f"({s['image_px'][0]}x{s['image_px'][1]}, JPEG {s['jpeg_kib']:.0f} KiB), MediaPipe {r['model']}, "
             f"{r['cpus']} CPUs, load average {r['load_average_before']:.1f} -> {r['load_average_after']:.1f}",
             f"{'stage (this process, one camera, 1 thread)':80} CPU ms/frame"]
    rows = [("MCAP read and parse", s["read_ms"]), ("frame task to a worker (pickle + unpickle)", s["transfer_ms"]),
            ("JPEG decode, full size", s["decode_full_ms"]), ("JPEG decode, half size (DCT scaling)", s["decode_half_ms"]),
            ("BGR -> RGB of the whole image", s["colour_full_ms"]), ("person detector, one run", s["person_detector_ms"]),
            ("landmark model, one run", s["landmarks_ms"])]
    for order in ("in_order", "gaps"):
        rows.append((f"decode + MediaPipe, {order.replace('_', ' ')} (person detector on "
                     f"{100 * s[f'person_detector_share_{order}']:.0f} %, {s[f'people_per_frame_{order}']:.2f} people)",
                     s[f"detect_{order}_ms"]))
    lines += [f"  {name:78} {ms:8.2f}" for name, ms in rows]
    lines.append(f"complete_keypoints, {r['workers']} worker processes   frames  wall s  frames/s  parent  workers  total")
    for e in r["end_to_end"]:
        lines.append(f"  {e['threads']} interpreter thread(s) per worker     {e['frames']:6d} {e['wall_s']:7.1f} "
                     f"{e['frames_per_s']:9.1f} {e['parent_cpu_ms']:7.2f} {e['workers_cpu_ms']:8.2f} {e['total_cpu_ms']:6.2f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cameras", type=int, default=4)
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--model", default="full", choices=["lite", "full", "heavy"])
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    emit(run(cameras=args.cameras, seconds=args.seconds, workers=args.workers, model=args.model), as_json=args.json,
         table=table)


if __name__ == "__main__":
    main()
