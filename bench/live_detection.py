"""Benchmark: live detection with the real MediaPipe detector pool, and the worker's processing after Stop.

A real walking recording is played by the video driver as N cameras in real time (``gaitcap node camera
--source video``) into the bus, through ``gaitcap node detector --detector mediapipe --workers W`` (real
processes) and the recorder. ``--source pose2sim`` (default): Pose2Sim's single-person demo, 4 real calibrated
cameras (1080x1920, 100 frames, played forwards then backwards to fill the trial); camera k plays source camera
k mod 4 at its calibrated pose, so 10 cameras carry 10 full streams and the trial can be reconstructed.
``--source sports2d``: the sports2d walk (one uncalibrated camera): detection only.

At Stop the live detector is stopped and the trial processed as the clinic's worker does (``recording_input``
+ ``process_trial``: preliminary, then every recorded frame without live keypoints detected from the MCAP's
images over W MediaPipe processes, then the refined fit, checks and kinematics; without a calibration the
completion alone).

Reports per camera: frames recorded, detected live (coverage), skipped by the live pool, the live lag (s,
camera node send -> keypoints published; the latest and the most seen); after Stop: preliminary stored,
complete detection, refined stored, all done (s); CPU after Stop; the load average at Stop and at the end;
final coverage; and the check against ``gaitcap detect`` on the same videos with the same detector (the final
keypoints of every camera frame vs the reference of that video frame: median joint distance, px, and the same
against the reference shifted by -2..+2 frames: the keypoints are frame for frame the reference's when offset
0 is the nearest; they differ by the JPEG compression of the recorded images and the tracking state).

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
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from gaitcap.reconstruction.camera import Rig  # noqa: E402
from gaitcap.services.processing.trial import NoSink  # noqa: E402

from bench._common import emit  # noqa: E402

VIDEO_FPS = 30.0
CLI = [sys.executable, "-c", "from gaitcap.services.cli import main; main()"]


@dataclass(frozen=True)
class Source:
    """A real walking recording the cameras play: ``videos`` (one per source camera; camera k of the bench
    plays video k mod len(videos)), ``calibration`` (the source cameras' rig, or None: nothing can be
    reconstructed, so Stop -> refined is not measured), ``ping_pong``: a short clip played forwards then
    backwards to fill the trial (the walker never jumps)."""

    name: str
    description: str
    videos: Callable[[], list[Path]]
    calibration: Callable[[], Rig | None]
    ping_pong: bool


def _installed(*parts: str) -> Path:
    from gaitcap.acquisition.installed import share_path

    path = share_path("testdata", *parts)
    if not path.exists():
        raise SystemExit(f"{path} missing: run deploy/bootstrap.sh")
    return path


def _pose2sim_rig() -> Rig:
    from gaitcap.acquisition.importers.tool_folders import read_qca

    return read_qca(_installed("pose2sim", "Demo_SinglePerson", "calibration", "Calib.qca.txt"))


SOURCES = {s.name: s for s in (
    Source("pose2sim", "Pose2Sim's single-person demo: 4 real calibrated cameras, 1080x1920, 100 frames",
           lambda: sorted(_installed("pose2sim", "Demo_SinglePerson", "videos").glob("cam*.mp4")), _pose2sim_rig,
           ping_pong=True),
    Source("sports2d", "the sports2d walk: one camera, 1768x994, 230 frames, no calibration",
           lambda: [_installed("sports2d-demo.mp4")], lambda: None, ping_pong=False),
)}


def _frame_order(count: int, total: int, *, ping_pong: bool) -> list[int]:
    """The source frame shown at each of ``total`` frames: looped, or forwards then backwards."""
    if not ping_pong or count < 2:
        return [k % count for k in range(total)]
    cycle = list(range(count)) + list(range(count - 2, 0, -1))
    return [cycle[k % len(cycle)] for k in range(total)]


def _played_files(folder: Path, source: Source, seconds: float) -> list[Path]:
    """Each source video cut, looped or played back and forth to last ``seconds`` at 30 fps."""
    import cv2

    played = []
    for n, video in enumerate(source.videos()):
        cap = cv2.VideoCapture(str(video))
        frames = [cap.read()[1] for _ in range(int(cap.get(cv2.CAP_PROP_FRAME_COUNT)))]
        cap.release()
        path = folder / f"source{n + 1}.mp4"
        h, w = frames[0].shape[:2]
        out = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), VIDEO_FPS, (w, h))
        for k in _frame_order(len(frames), math.ceil(seconds * VIDEO_FPS), ping_pong=source.ping_pong):
            out.write(frames[k])
        out.release()
        played.append(path)
    return played


def _camera_files(folder: Path, played: list[Path], cameras: int) -> list[Path]:
    """One file per camera (camera = file stem): camera k plays ``played[k mod len(played)]``."""
    files = []
    for c in range(cameras):
        link = folder / f"cam{c + 1:02d}.mp4"
        link.symlink_to(played[c % len(played)])
        files.append(link)
    return files


def bench_rig(source: Source, cameras: int) -> Rig | None:
    """The rig of the bench's cameras: camera k is source camera k mod n, at its pose (cameras 5-10 of a
    4-camera source see exactly what cameras 1-4 see), or None when the source has no calibration."""
    rig = source.calibration()
    if rig is None:
        return None
    cams = [replace(rig.cameras[c % len(rig.cameras)], name=f"cam{c + 1:02d}") for c in range(cameras)]
    return Rig(cams)


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


def live_trial(*, files: list[Path], seconds: float, workers: int, model: str, out: Path) -> tuple[Path, dict]:
    """Record one trial of ``files`` (one per camera) through the live detector pool; (MCAP, live coverage
    at Stop)."""
    from gaitcap.services.bus.control import RecorderClient
    from gaitcap.services.bus.session import BusConfig, free_loopback_ports, open_session

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
    return path, live


def reference(videos: list[Path], model: str) -> list[np.ndarray]:
    """``gaitcap detect`` on each played video (the cameras that play it share it): [(T, P, 33, 3)]."""
    from gaitcap.acquisition.detectors.mediapipe import MediaPipeConfig
    from gaitcap.acquisition.video_detect import detect_videos

    return [detect_videos([v], MediaPipeConfig(model=model, num_threads=1).build()).keypoints[0] for v in videos]


def reference_of_recorded_images(videos: list[Path], model: str, *, jpeg_quality: int = 90) -> list[np.ndarray]:
    """The same detector on each played video's frames as the recording holds them (JPEG-compressed at the
    camera node's quality, then decoded), frame after frame as ``gaitcap detect`` does: [(T, P, 33, 3)].
    Completing every frame (the default; not ``--only-missing``) must give exactly these."""
    import cv2
    from gaitcap.acquisition.detectors.mediapipe import MediaPipeConfig
    from gaitcap.acquisition.encoding import decode_jpeg, encode_jpeg

    detector, refs = MediaPipeConfig(model=model, num_threads=1).build(), []
    for video in videos:
        cap, found = cv2.VideoCapture(str(video)), []
        ok, image = cap.read()
        while ok:
            people = detector.detect(decode_jpeg(encode_jpeg(image, quality=jpeg_quality)), camera=video.stem,
                                     frame_id=len(found), timestamp_ns=int(len(found) * 1e9 / VIDEO_FPS))
            found.append(np.asarray(people, dtype=np.float64).reshape(-1, detector.skeleton.num_joints, 3))
            ok, image = cap.read()
        cap.release()
        out = np.full((len(found), max([1, *map(len, found)]), detector.skeleton.num_joints, 3), np.nan)
        out[..., 2] = 0.0
        for t, people in enumerate(found):
            out[t, : len(people)] = people
        refs.append(out)
    return refs


def agreement_px(people: np.ndarray, frame_ids: np.ndarray, refs: list[np.ndarray], keep: np.ndarray, *,
                 offset: int = 0, min_conf: float = 0.5) -> dict:
    """Per camera frame: the median distance (px) between the final first person and the nearest person of the
    reference frame ``offset`` frames later, over the joints both see; frames where only one of them finds
    someone counted apart. ``refs[c]``: camera c's reference; ``keep`` (C, T) bool: the camera frames compared."""
    dists, here_only, reference_only = [], 0, 0
    for c in range(people.shape[0]):
        ref = refs[c]
        for t, fid in enumerate(frame_ids):
            fid = fid + offset
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
            "within_2px": float((d <= 2).mean()) if d.size else None,
            "identical": float((d <= 1e-9).mean()) if d.size else None, "found_by_one_only": here_only + reference_only,
            "found_here_only": here_only, "found_by_reference_only": reference_only}


def frame_alignment(kp, refs: list[np.ndarray], keep: np.ndarray, offsets=(-2, -1, 0, 1, 2)) -> dict:
    """The median distance (px) to the reference shifted by each offset (frames): the final keypoints are
    frame for frame the reference's when offset 0 is the nearest."""
    medians = {k: agreement_px(kp.keypoints, kp.frame_ids, refs, keep, offset=k)["median_px"] for k in offsets}
    known = {k: v for k, v in medians.items() if v is not None}
    return {"median_px_by_offset": medians, "best_offset": min(known, key=known.get) if known else None}


def _median_px(a: np.ndarray, b: np.ndarray, min_conf: float) -> float | None:
    ok = (a[:, 2] > min_conf) & (b[:, 2] > min_conf)
    return float(np.median(np.hypot(*(a[ok, :2] - b[ok, :2]).T))) if ok.any() else None


def _children_cpu_s() -> float:
    """User + system CPU s of this process's finished children (the completion's workers once its pool closed)."""
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    return used.ru_utime + used.ru_stime


class TimedSink(NoSink):
    """The one processing path's sink (:class:`NoSink` otherwise) that notes when each step started and each stage was stored (s
    after ``t0``, ``time.perf_counter``)."""

    def __init__(self, t0: float):
        self.t0, self.started, self.stored_at = t0, {}, {}

    def progress(self, step: str, fraction: float, result: str | None) -> None:
        self.started.setdefault(step, time.perf_counter() - self.t0)

    def stored(self, outcome, quality) -> None:
        self.stored_at[outcome.name] = time.perf_counter() - self.t0


def complete_only(path: Path, settings) -> tuple[object, dict, dict]:
    """No calibration: the completion alone, as the worker runs it; (keypoints, per-camera report, times s)."""
    from gaitcap.acquisition.recording.reader import read_keypoints
    from gaitcap.services.processing.completion import complete_with

    t0 = time.perf_counter()
    try:
        recording = read_keypoints(path)
    except ValueError:  # nothing detected live
        recording = None
    kp, report = complete_with(path, recording, settings)
    return kp, {c.camera: c.to_dict() for c in report.cameras}, {"complete": time.perf_counter() - t0}


def process_recorded(path: Path, rig: Rig, settings, out: Path) -> tuple[object, dict, dict]:
    """The worker's processing of the trial (``recording_input`` + ``process_trial`` with the clinic's
    stages, the completion before the refined stage, files, checks and kinematics): (the complete keypoints,
    the per-camera completion report, times s after Stop: preliminary / complete / refined stored, all done)."""
    from gaitcap.acquisition.readers import load_multi_npz
    from gaitcap.acquisition.writers import save_rig
    from gaitcap.services.processing.artifacts import TrialFiles
    from gaitcap.services.processing.completion import KEYPOINTS_FILE, REPORT_FILE
    from gaitcap.services.processing.trial import TrialOptions, process_trial, recording_input

    calibration = save_rig(rig, out / "calibration.json")
    t0 = time.perf_counter()
    sink = TimedSink(t0)
    data = recording_input(path, fallback_calibration=calibration, completion=settings)
    result = process_trial(data, TrialOptions(completion=settings), files=TrialFiles(out / "trial"), sink=sink)
    done = time.perf_counter() - t0
    refining = next((v for k, v in sink.started.items() if k.startswith("refining")), None)
    times = {"preliminary": sink.stored_at.get("preliminary"), "complete": refining,
             "refined": sink.stored_at.get("refined"), "all_done": done, "failed": result.failed,
             "completion_step": result.timings_s.get("completion")}
    report = json.loads((out / "trial" / REPORT_FILE).read_text())
    return load_multi_npz(out / "trial" / KEYPOINTS_FILE), report["cameras"], times


def run(*, source: str, cameras: int, seconds: float, workers: int, model: str, check: bool,
        only_missing: bool = False) -> dict:
    """One trial; after Stop every recorded frame detected again (the clinic's default), or with
    ``only_missing`` only those without live keypoints."""
    from gaitcap.acquisition.detectors.mediapipe import MediaPipeConfig
    from gaitcap.acquisition.recording.reader import read_keypoints
    from gaitcap.reconstruction.keypoints import COMPLETED, LIVE
    from gaitcap.services.processing.completion import CompletionSettings

    src = SOURCES[source]
    settings = CompletionSettings(MediaPipeConfig(model=model, num_threads=1), workers=workers,
                                  redetect_all=not only_missing)
    with tempfile.TemporaryDirectory(prefix="livedet-") as tmp:
        out = Path(tmp)
        played = _played_files(out, src, seconds)
        files, rig = _camera_files(out, played, cameras), bench_rig(src, cameras)
        path, live = live_trial(files=files, seconds=seconds, workers=workers, model=model, out=out)
        load_at_stop = os.getloadavg()[0]
        cpu0, workers0 = time.process_time(), _children_cpu_s()
        kp, report, times = (complete_only(path, settings) if rig is None
                             else process_recorded(path, rig, settings, out))
        cpu = {"parent": time.process_time() - cpu0, "workers": _children_cpu_s() - workers0}
        load_at_end = os.getloadavg()[0]
        try:
            recording = read_keypoints(path)
            live_counts = {c: int((recording.timestamps_ns[i] >= 0).sum())
                           for i, c in enumerate(recording.camera_names)}
        except ValueError:  # nothing detected live
            live_counts = {}
        agree = None
        if check:
            agree = {}
            for ref_name, refs in (("video", reference(played, model)),
                                   ("recorded images", reference_of_recorded_images(played, model))):
                per_camera = [refs[c % len(refs)] for c in range(len(kp.camera_names))]
                agree[ref_name] = {name: agreement_px(kp.keypoints, kp.frame_ids, per_camera, kp.provenance == code)
                                   for name, code in (("completed", COMPLETED), ("live", LIVE))}
                agree[ref_name]["frames"] = frame_alignment(kp, per_camera, kp.provenance > 0)
    return _summary(src, cameras=cameras, seconds=seconds, workers=workers, model=model, live=live,
                    live_counts=live_counts, report=report, times=times, cpu=cpu, agree=agree,
                    load=(load_at_stop, load_at_end), redetect_all=not only_missing)


def _summary(src: Source, *, cameras: int, seconds: float, workers: int, model: str, live: dict, live_counts: dict,
             report: dict, times: dict, cpu: dict, agree: dict | None, load: tuple, redetect_all: bool) -> dict:
    rows = {}
    status = live["status"]
    for cam, done in report.items():
        row = (status.cameras.get(cam) if status else None) or {}
        n_live = live_counts.get(cam, 0)
        rows[cam] = {"recorded": done["recorded"], "live": n_live, "live_coverage": n_live / max(done["recorded"], 1),
                     "skipped_live": row.get("skipped", 0), "lag_s": row.get("lag_s"),
                     "max_lag_s": live["max_lag_s"].get(cam), "completed": done["completed"],
                     "corrupt": done["corrupt"], "final_coverage": done["coverage"], "missing": done["missing"]}
    recorded = sum(r["recorded"] for r in rows.values())
    completed = sum(r["completed"] for r in rows.values())
    missing = sum(r["missing"] for r in rows.values())
    refined = times.get("refined")
    return {"source": src.name, "source_description": src.description, "cameras": cameras, "seconds": seconds,
            "workers": workers, "model": model, "cpus": os.cpu_count(),
            "completion": "every frame" if redetect_all else "frames without live keypoints",
            "frames_recorded": recorded, "frames_live": sum(r["live"] for r in rows.values()),
            "live_coverage": sum(r["live"] for r in rows.values()) / max(recorded, 1),
            "final_coverage": 1 - missing / max(recorded, 1),
            "stop_to_preliminary_s": times.get("preliminary"), "stop_to_complete_s": times["complete"],
            "stop_to_refined_s": refined, "stop_to_all_done_s": times.get("all_done"),
            "stages_failed": times.get("failed", {}), "per_camera": rows, "agreement_with_detect": agree,
            "cpu_after_stop": {"parent_s": cpu["parent"],
                               "workers_ms_per_completed_frame": 1e3 * cpu["workers"] / max(1, completed)},
            "load_average": {"stop": load[0], "end": load[1]},
            "targets_met": {"final_coverage_100pct": missing == 0,
                            "stop_to_refined_within_3min": None if refined is None else refined <= 180.0}}


def _s(value: float | None) -> str:
    return "not measured" if value is None else f"{value:.1f} s"


def _agreement_lines(ref_name: str, against: dict) -> list[str]:
    against = dict(against)
    frames, lines = against.pop("frames"), []
    for name, a in against.items():
        if not a["frames_compared"]:
            continue
        lines.append(f"vs gaitcap detect on the {ref_name}, {name} frames: {a['frames_compared']} camera frames, "
                     f"median {a['median_px']:.2f} px, p95 {a['p95_px']:.2f} px, {100 * a['within_2px']:.0f} % within "
                     f"2 px, {100 * a['identical']:.0f} % identical, {a['found_by_one_only']} found by only one "
                     f"({a['found_here_only']} here only, {a['found_by_reference_only']} by gaitcap detect only)")
    by = ", ".join(f"{int(k):+d}: {'-' if v is None else f'{v:.2f}'}" for k, v in frames["median_px_by_offset"].items())
    lines.append(f"  frame for frame: median px to its frame shifted by ({by}); nearest at offset "
                 f"{frames['best_offset']}")
    return lines


def table(r: dict) -> str:
    lines = [f"live detection: {r['cameras']} cameras x {r['seconds']:g} s at 30 fps ({r['source_description']}), "
             f"MediaPipe {r['model']}, {r['workers']} worker processes, {r['cpus']} CPUs",
             f"{'camera':8} {'recorded':>8} {'live':>6} {'live %':>7} {'skipped':>8} {'lag s':>6} {'max lag':>8} "
             f"{'completed':>9} {'final %':>8}"]
    for cam, row in r["per_camera"].items():
        lag = "-" if row["lag_s"] is None else f"{row['lag_s']:.2f}"
        mx = "-" if row["max_lag_s"] is None else f"{row['max_lag_s']:.2f}"
        lines.append(f"{cam:8} {row['recorded']:8d} {row['live']:6d} {100 * row['live_coverage']:6.1f}% "
                     f"{row['skipped_live']:8d} {lag:>6} {mx:>8} {row['completed']:9d} {100 * row['final_coverage']:7.1f}%")
    cpu, load = r["cpu_after_stop"], r["load_average"]
    lines.append(f"all: {r['frames_recorded']} frames recorded, live coverage {100 * r['live_coverage']:.1f} %, "
                 f"final coverage {100 * r['final_coverage']:.1f} % ({r['completion']} detected after Stop)")
    lines.append(f"after Stop: preliminary stored {_s(r['stop_to_preliminary_s'])}, complete detection "
                 f"{_s(r['stop_to_complete_s'])}, refined stored {_s(r['stop_to_refined_s'])}, all done (checks, "
                 f"kinematics) {_s(r['stop_to_all_done_s'])}" + (f"; FAILED: {r['stages_failed']}" if r["stages_failed"]
                                                                    else ""))
    lines.append(f"CPU after Stop: {cpu['parent_s']:.1f} s this process (reading, fits, files), completion workers "
                 f"{cpu['workers_ms_per_completed_frame']:.1f} ms per completed frame (start-up included); load average "
                 f"{load['stop']:.1f} at Stop, {load['end']:.1f} at the end")
    for ref_name, against in (r["agreement_with_detect"] or {}).items():
        lines += _agreement_lines(ref_name, against)
    lines.append(f"targets: {r['targets_met']}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--source", default="pose2sim", choices=sorted(SOURCES),
                    help="what the cameras play (pose2sim: calibrated, so the trial is processed to the refined result)")
    ap.add_argument("--cameras", type=int, default=10)
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--workers", type=int, default=None, help="detector processes (default: one per CPU core)")
    ap.add_argument("--model", default="full", choices=["lite", "full", "heavy"])
    ap.add_argument("--no-check", action="store_true", help="skip the comparison with gaitcap detect")
    ap.add_argument("--only-missing", action="store_true",
                    help="after Stop detect only the frames without live keypoints (default: every frame, as the clinic)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    from gaitcap.acquisition.detectors.pool import default_workers

    result = run(source=args.source, cameras=args.cameras, seconds=args.seconds,
                 workers=args.workers or default_workers(), model=args.model, check=not args.no_check,
                 only_missing=args.only_missing)
    emit(result, as_json=args.json, table=table)


if __name__ == "__main__":
    main()
