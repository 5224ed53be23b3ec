"""Benchmark: live detection with the real MediaPipe detector pool, and the completion after Stop.

The sports2d walking video (1768x994, 30 fps, 230 frames; installed by deploy/bootstrap.sh) is played by the
video driver as N cameras in real time (``gaitcap node camera --source video``; longer trials loop it) into
the bus, through ``gaitcap node detector --detector mediapipe --workers W`` (real processes) and the
recorder. At Stop the live detector is stopped and the trial completed: every recorded frame without live
keypoints detected from the MCAP's images (``complete_keypoints``, MediaPipe over W worker processes).

Reports per camera: frames recorded, detected live (coverage), skipped by the live pool, the live lag (s,
camera node send -> keypoints published; the latest and the most seen); Stop -> complete detection (s);
the completion's CPU per completed frame (ms: this process's and its worker processes', not wall time, which
a shared machine makes noisy) and the load average at Stop and at the end; final coverage; and the check against ``gaitcap detect`` on the same video with the same detector (the
final keypoints of every camera frame vs the reference of that video frame: median joint distance, px;
they differ by the JPEG compression of the recorded images and the tracking state, not by the frame).

    python bench/live_detection.py --cameras 4 --seconds 8 --workers 2
    python bench/live_detection.py --cameras 10 --seconds 30 --workers 2 --json
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from bench._common import emit  # noqa: E402

VIDEO_FPS = 30.0
CLI = [sys.executable, "-c", "from gaitcap.services.cli import main; main()"]


def _video() -> Path:
    from gaitcap.acquisition.installed import share_path

    path = share_path("testdata", "sports2d-demo.mp4")
    if not path.is_file():
        raise SystemExit(f"{path} missing: run deploy/bootstrap.sh")
    return path


def _camera_files(folder: Path, cameras: int, seconds: float) -> list[Path]:
    """One file per camera (camera = file stem): the video cut or looped to last ``seconds``."""
    import cv2

    cap = cv2.VideoCapture(str(_video()))
    frames = [cap.read()[1] for _ in range(int(cap.get(cv2.CAP_PROP_FRAME_COUNT)))]
    cap.release()
    source = folder / "walk.mp4"
    h, w = frames[0].shape[:2]
    out = cv2.VideoWriter(str(source), cv2.VideoWriter_fourcc(*"mp4v"), VIDEO_FPS, (w, h))
    for k in range(math.ceil(seconds * VIDEO_FPS)):
        out.write(frames[k % len(frames)])
    out.release()
    files = []
    for c in range(cameras):
        link = folder / f"cam{c + 1:02d}.mp4"
        link.symlink_to(source)
        files.append(link)
    return files


class StatusLog:
    """The detector node's coverage messages: the latest, and the most lag seen per camera."""

    def __init__(self):
        self.lock, self.latest, self.max_lag = threading.Lock(), None, {}

    def __call__(self, sample):
        from gaitcap.services.bus.messages import DetectorStatus

        msg = DetectorStatus.from_bytes(sample.payload.to_bytes())
        with self.lock:
            self.latest = msg
            for cam, row in msg.cameras.items():
                if row["lag_s"] is not None:
                    self.max_lag[cam] = max(self.max_lag.get(cam, 0.0), row["lag_s"])


def _spawn(args: list[str], log: Path) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.Popen([*CLI, *args], env=env, cwd=str(ROOT), stdout=open(log, "w"), stderr=subprocess.STDOUT)


def _stop(proc: subprocess.Popen, timeout_s: float = 30) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def _wait_alive(session, bus, names: set[str], procs: dict, timeout_s: float) -> None:
    from gaitcap.services.bus.session import alive_nodes

    end = time.monotonic() + timeout_s
    while not names <= alive_nodes(session, bus):
        dead = [n for n, p in procs.items() if p.poll() is not None]
        if dead or time.monotonic() > end:
            raise RuntimeError(f"node(s) {dead or sorted(names)} did not come up (see their logs)")
        time.sleep(0.2)


def live_trial(*, cameras: int, seconds: float, workers: int, model: str, out: Path) -> tuple[Path, dict, list[Path]]:
    """Record one trial through the live detector pool; (MCAP, live coverage at Stop, camera files)."""
    from gaitcap.services.bus.control import RecorderClient
    from gaitcap.services.bus.session import BusConfig, free_loopback_ports, open_session

    files = _camera_files(out, cameras, seconds)
    names = ["recorder", "detector", "camera-0", "bench"]
    bus = BusConfig({n: f"tcp/127.0.0.1:{p}" for n, p in zip(names, free_loopback_ports(4), strict=True)},
                    prefix="gaitcap/livedet")
    bus_file = out / "bus.json"
    bus_file.write_text(json.dumps(bus.to_dict()))
    bus_arg = ["--bus", str(bus_file)]
    procs = {"recorder": _spawn(["node", "recorder", "--node", "recorder", *bus_arg, "--data-dir", str(out)],
                                out / "recorder.log"),
             "detector": _spawn(["node", "detector", "--node", "detector", *bus_arg, "--detector", "mediapipe",
                                 "--param", f"model={model}", "--param", "num_threads=1", "--workers", str(workers)],
                                out / "detector.log")}
    session = open_session(bus, "bench")
    status = StatusLog()
    sub = session.declare_subscriber(bus.keys.detector_status("detector"), status)
    try:
        _wait_alive(session, bus, {"recorder", "detector"}, procs, 180)
        client = RecorderClient(session, bus.keys, timeout_s=120)
        path = out / "trial.mcap"
        client.start(trial_id="bench", path=str(path), metadata={"bench": "live_detection"})
        cam = _spawn(["node", "camera", "--node", "camera-0", *bus_arg, "--source", "video", "--fps", str(VIDEO_FPS),
                      *[a for f in files for a in ("--video", str(f))]], out / "camera.log")
        procs["camera"] = cam
        cam.wait(timeout=seconds + 120)  # the file ends after ``seconds``
        end = time.monotonic() + 30
        while client.status().queued and time.monotonic() < end:
            time.sleep(0.1)
        client.stop("bench")
        with status.lock:
            live = {"status": status.latest, "max_lag_s": dict(status.max_lag)}
    finally:
        sub.undeclare()
        session.close()
        for p in procs.values():
            _stop(p)
    return path, live, files


def reference(video: Path, model: str) -> np.ndarray:
    """``gaitcap detect`` on one camera's video (every camera plays the same): (T, P, 33, 3)."""
    from gaitcap.acquisition.detectors.mediapipe import MediaPipeConfig
    from gaitcap.acquisition.video_detect import detect_videos

    return detect_videos([video], MediaPipeConfig(model=model, num_threads=1).build()).keypoints[0]


def agreement_px(people: np.ndarray, frame_ids: np.ndarray, ref: np.ndarray, keep: np.ndarray,
                 min_conf: float = 0.5) -> dict:
    """Per camera frame: the median distance (px) between the final first person and the nearest person of the
    reference, over the joints both see; frames where only one of them finds someone counted apart. ``keep``
    (C, T) bool: the camera frames compared."""
    dists, here_only, reference_only = [], 0, 0
    for c in range(people.shape[0]):
        for t, fid in enumerate(frame_ids):
            if not 0 <= fid < ref.shape[0] or not keep[c, t]:
                continue
            a = people[c, t, 0]
            others = [b for b in ref[fid] if (b[:, 2] > min_conf).any()]
            has_a = (a[:, 2] > min_conf).any()
            here_only += has_a and not others
            reference_only += bool(others) and not has_a
            if has_a and others:
                found = [_median_px(a, b, min_conf) for b in others]
                found = [d for d in found if d is not None]
                if found:
                    dists.append(min(found))
    d = np.array(dists)
    return {"frames_compared": int(d.size), "median_px": float(np.median(d)) if d.size else None,
            "p95_px": float(np.percentile(d, 95)) if d.size else None,
            "within_2px": float((d <= 2).mean()) if d.size else None, "found_by_one_only": here_only + reference_only,
            "found_here_only": here_only, "found_by_reference_only": reference_only}


def _median_px(a: np.ndarray, b: np.ndarray, min_conf: float) -> float | None:
    ok = (a[:, 2] > min_conf) & (b[:, 2] > min_conf)
    return float(np.median(np.hypot(*(a[ok, :2] - b[ok, :2]).T))) if ok.any() else None


def _children_cpu_s() -> float:
    """User + system CPU s of this process's finished children (the completion's workers once its pool closed)."""
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    return used.ru_utime + used.ru_stime


def run(*, cameras: int, seconds: float, workers: int, model: str, check: bool, redetect_all: bool = False) -> dict:
    from gaitcap.acquisition.detectors.mediapipe import MediaPipeConfig
    from gaitcap.acquisition.recording.reader import read_keypoints
    from gaitcap.reconstruction.keypoints import COMPLETED, LIVE
    from gaitcap.services.processing.completion import complete_keypoints

    with tempfile.TemporaryDirectory(prefix="livedet-") as tmp:
        out = Path(tmp)
        path, live, files = live_trial(cameras=cameras, seconds=seconds, workers=workers, model=model, out=out)
        t0, load_at_stop = time.perf_counter(), os.getloadavg()[0]
        cpu0, workers0 = time.process_time(), _children_cpu_s()
        try:
            recording = read_keypoints(path)
        except ValueError:  # nothing detected live
            recording = None
        kp, report = complete_keypoints(path, recording, MediaPipeConfig(model=model, num_threads=1).build,
                                        detector_name=f"mediapipe {model}", workers=workers,
                                        redetect_all=redetect_all)
        stop_to_complete = time.perf_counter() - t0
        cpu = {"parent": time.process_time() - cpu0, "workers": _children_cpu_s() - workers0}
        load_at_end = os.getloadavg()[0]
        live_counts = {} if recording is None else {
            c: int((recording.timestamps_ns[i] >= 0).sum()) for i, c in enumerate(recording.camera_names)}
        agree = None
        if check:
            ref = reference(files[0], model)
            agree = {name: agreement_px(kp.keypoints, kp.frame_ids, ref, kp.provenance == code)
                     for name, code in (("completed", COMPLETED), ("live", LIVE))}
    rows = {}
    status = live["status"]
    for cam in report.cameras:
        row = (status.cameras.get(cam.camera) if status else None) or {}
        n_live = live_counts.get(cam.camera, 0)
        rows[cam.camera] = {"recorded": cam.recorded, "live": n_live, "live_coverage": n_live / max(cam.recorded, 1),
                            "skipped_live": row.get("skipped", 0), "lag_s": row.get("lag_s"),
                            "max_lag_s": live["max_lag_s"].get(cam.camera), "completed": cam.completed,
                            "corrupt": len(cam.corrupt_frame_ids), "final_coverage": cam.coverage,
                            "missing": len(cam.missing_frame_ids)}
    recorded = sum(r["recorded"] for r in rows.values())
    completed = sum(r["completed"] for r in rows.values())
    return {"cameras": cameras, "seconds": seconds, "workers": workers, "model": model, "cpus": os.cpu_count(),
            "completion": "every frame" if redetect_all else "frames without live keypoints",
            "frames_recorded": recorded, "frames_live": sum(r["live"] for r in rows.values()),
            "live_coverage": sum(r["live"] for r in rows.values()) / max(recorded, 1),
            "final_coverage": 1 - sum(r["missing"] for r in rows.values()) / max(recorded, 1),
            "stop_to_complete_s": stop_to_complete, "per_camera": rows, "agreement_with_detect": agree,
            "completion_cpu_ms_per_frame": {k: 1e3 * v / max(1, completed) for k, v in cpu.items()},
            "load_average": {"stop": load_at_stop, "end": load_at_end},
            "targets_met": {"final_coverage_100pct": report.complete}}


def table(r: dict) -> str:
    lines = [f"live detection: {r['cameras']} cameras x {r['seconds']:g} s at 30 fps (sports2d video), MediaPipe "
             f"{r['model']}, {r['workers']} worker processes, {r['cpus']} CPUs",
             f"{'camera':8} {'recorded':>8} {'live':>6} {'live %':>7} {'skipped':>8} {'lag s':>6} {'max lag':>8} "
             f"{'completed':>9} {'final %':>8}"]
    for cam, row in r["per_camera"].items():
        lag = "-" if row["lag_s"] is None else f"{row['lag_s']:.2f}"
        mx = "-" if row["max_lag_s"] is None else f"{row['max_lag_s']:.2f}"
        lines.append(f"{cam:8} {row['recorded']:8d} {row['live']:6d} {100 * row['live_coverage']:6.1f}% "
                     f"{row['skipped_live']:8d} {lag:>6} {mx:>8} {row['completed']:9d} {100 * row['final_coverage']:7.1f}%")
    cpu, load = r["completion_cpu_ms_per_frame"], r["load_average"]
    lines.append(f"all: {r['frames_recorded']} frames recorded, live coverage {100 * r['live_coverage']:.1f} %, "
                 f"final coverage {100 * r['final_coverage']:.1f} %; Stop -> complete detection "
                 f"{r['stop_to_complete_s']:.1f} s ({r['completion']})")
    lines.append(f"completion CPU per completed frame: {cpu['parent']:.1f} ms this process + {cpu['workers']:.1f} ms "
                 f"workers (start-up included); load average {load['stop']:.1f} at Stop, {load['end']:.1f} at the end")
    for name, a in (r["agreement_with_detect"] or {}).items():
        if not a["frames_compared"]:
            continue
        lines.append(f"vs gaitcap detect on the video, {name} frames: {a['frames_compared']} camera frames, median "
                     f"{a['median_px']:.2f} px, p95 {a['p95_px']:.2f} px, {100 * a['within_2px']:.0f} % within 2 px, "
                     f"{a['found_by_one_only']} found by only one "
                     f"({a['found_here_only']} here only, {a['found_by_reference_only']} by gaitcap detect only)")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cameras", type=int, default=10)
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--workers", type=int, default=None, help="detector processes (default: one per CPU core)")
    ap.add_argument("--model", default="full", choices=["lite", "full", "heavy"])
    ap.add_argument("--no-check", action="store_true", help="skip the comparison with gaitcap detect")
    ap.add_argument("--redetect-all", action="store_true", help="after Stop detect every frame, the live ones too")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    from gaitcap.acquisition.detectors.pool import default_workers

    result = run(cameras=args.cameras, seconds=args.seconds, workers=args.workers or default_workers(),
                 model=args.model, check=not args.no_check, redetect_all=args.redetect_all)
    emit(result, as_json=args.json, table=table)


if __name__ == "__main__":
    main()
