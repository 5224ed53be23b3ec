"""Benchmark: resident memory of one process writing a trial's Rerun file (.rrd) again and again.

Simulates one walk (``--seconds``, ``--cameras``, with small images), writes it as the recorder does, builds
the viewers' TrialView of it and writes its .rrd ``--writes`` times, as a worker writes one per trial:
``apart`` (the worker's way: each file in a child process, :mod:`gaitcap.services.processing.viewers.apart`)
and, with ``--in-process``, also in this process (as before). After each write: garbage collected, the C
heap trimmed (glibc ``malloc_trim``, as the worker does after a job), this process's resident memory (MB)
and, for ``apart``, with its children (the server the writers are forked from). The slope is a least-squares
fit over the writes after the first third (MB per file).

    python bench/viewer_memory.py --writes 25 --in-process      # a table
    python bench/viewer_memory.py --writes 25 --json            # one JSON object
"""

from __future__ import annotations

import argparse
import gc
import logging
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from bench._common import emit  # noqa: E402


def _view(folder: Path, *, seconds: float, cameras: int):
    from gaitcap.acquisition.recording.reader import read_keypoints
    from gaitcap.reconstruction.gait import analyze_gait
    from gaitcap.reconstruction.result import Reconstruction
    from gaitcap.services.processing.artifacts import TrialFiles
    from gaitcap.services.processing.viewers.files import trial_view
    from gaitcap.simulator import make_trial
    from gaitcap.simulator.recording import write_keypoint_recording

    files = TrialFiles(folder)
    folder.mkdir(parents=True)
    walk = make_trial("paper", seconds=seconds, cameras=cameras, people=1, seed=2, fps=30.0)
    write_keypoint_recording(walk, files.recording, stills=True)
    kps = read_keypoints(files.recording)
    traj = Reconstruction("truth", walk.points_mm, kps.times_s, walk.skeleton.joint_names)
    report = analyze_gait(traj.points_mm, traj.times_s, list(traj.joint_names))
    return trial_view("bench", traj, detections=kps.patient(), keypoints=kps, rig=walk.rig, report=report,
                      recording=files.recording, bones=walk.skeleton.bone_indices)


def _series(write, view, folder: Path, writes: int, settings) -> dict:
    from gaitcap.services.ops.soak import rss_mb
    from gaitcap.services.processing.compiled_code import trim_heap
    from gaitcap.services.processing.worker import resident_mb

    from bench.worker_memory import slope_per_trial

    rss, family, seconds = [], [], []
    for k in range(writes):
        t0 = time.perf_counter()
        write(folder / f"{k}.rrd", view, settings)
        seconds.append(time.perf_counter() - t0)
        gc.collect()
        trim_heap()
        rss.append(round(resident_mb(), 1))
        family.append(round(rss_mb(os.getpid()), 1))
    skip = writes // 3
    return {"rss_mb": rss, "with_children_mb": family, "write_s": [round(s, 2) for s in seconds],
            "slope_mb_per_file": slope_per_trial(rss[skip:]),
            "with_children_slope_mb_per_file": slope_per_trial(family[skip:]),
            "file_bytes": (folder / "0.rrd").stat().st_size}


def run(args) -> dict:
    from gaitcap.services.processing.viewers.apart import write_rrd_apart
    from gaitcap.services.processing.viewers.rerun_trial import RerunSettings, write_trial_rrd

    settings = RerunSettings(image_rate_hz=args.image_rate_hz)
    with tempfile.TemporaryDirectory(prefix="gaitcap-viewer-memory-") as tmp:
        view = _view(Path(tmp) / "trial", seconds=args.seconds, cameras=args.cameras)
        out = {"writes": args.writes, "seconds": args.seconds, "cameras": args.cameras,
               "image_rate_hz": args.image_rate_hz,
               "apart": _series(write_rrd_apart, view, Path(tmp) / "trial", args.writes, settings)}
        if args.in_process:
            out["in_process"] = _series(write_trial_rrd, view, Path(tmp) / "trial", args.writes, settings)
    return out


def _table(r: dict) -> str:
    lines = [f"viewer memory: the .rrd of a {r['seconds']:.0f} s walk, {r['cameras']} cameras, images at "
             f"{r['image_rate_hz']:g}/s, written {r['writes']} times by one process"]
    for name in ("apart", "in_process"):
        if name not in r:
            continue
        s = r[name]
        lines.append(f"{name}: {s['file_bytes'] / 1e6:.1f} MB per file, median write "
                     f"{sorted(s['write_s'])[len(s['write_s']) // 2]:.2f} s")
        lines.append(f"  RSS MB after each: {' '.join(f'{v:.0f}' for v in s['rss_mb'])}  "
                     f"(slope {s['slope_mb_per_file']:+.2f} MB per file)")
        lines.append(f"  with children MB:  {' '.join(f'{v:.0f}' for v in s['with_children_mb'])}  "
                     f"(slope {s['with_children_slope_mb_per_file']:+.2f} MB per file)")
    return "\n".join(lines)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--writes", type=int, default=25)
    p.add_argument("--seconds", type=float, default=6.0, help="The walk (s).")
    p.add_argument("--cameras", type=int, default=10)
    p.add_argument("--image-rate-hz", type=float, default=5.0, help="Images per second and camera in the .rrd.")
    p.add_argument("--in-process", action="store_true", help="Also write them in this process (as before).")
    p.add_argument("--json", action="store_true")
    args = p.parse_args()
    logging.basicConfig(level=logging.WARNING, stream=sys.stderr, format="%(asctime)s %(name)s %(message)s")
    emit(run(args), as_json=args.json, table=_table)


if __name__ == "__main__":
    main()
