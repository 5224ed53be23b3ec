"""The detector pool with real worker processes: routing by camera, batching, a worker killed."""

import functools
import os
import signal
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from gaitcap.acquisition.detectors.pool import DetectorPool, FrameTask
from gaitcap.acquisition.encoding import encode_jpeg

from .conftest import wait_for

sys.path.insert(0, str(Path(__file__).parent))
import pool_helpers  # noqa: E402  (spawned workers import it by name from sys.path)

JPEG = encode_jpeg(np.zeros((24, 32, 3), np.uint8))


class Results:
    def __init__(self):
        self.lock, self.items = threading.Lock(), []

    def __call__(self, result):
        with self.lock:
            self.items.append((time.monotonic(), result))

    def of(self, camera):
        with self.lock:
            return [r for _, r in self.items if r.task.camera == camera]


def task(camera, frame_id, jpeg=JPEG):
    return FrameTask(camera, frame_id, frame_id * 33_333_333, time.time_ns(), jpeg)


def test_frames_are_routed_by_camera_and_batched():
    got = Results()
    pool = DetectorPool.of_processes(functools.partial(pool_helpers.BatchDetector, 0.02), 2, got, max_batch=4)
    try:
        for f in range(12):
            for cam in ("cam01", "cam02", "cam03", "cam04"):
                pool.submit(task(cam, f))
        pool.submit(task("cam01", 99, b"not a jpeg"))
        wait_for(lambda: len(got.items) == 49, 30, "every frame detected")
        for cam in ("cam01", "cam02", "cam03", "cam04"):
            workers = {r.worker for r in got.of(cam)}
            assert len(workers) == 1, f"{cam} went to workers {workers}"
        assert sorted(pool.assignment().values()) == [0, 0, 1, 1]  # two cameras per worker
        ok = [r for _, r in got.items if r.error is None]
        assert max(r.people[0, 0, 1] for r in ok) > 1  # frames were detected in batches
        bad = [r for _, r in got.items if r.error is not None]
        assert [(r.task.camera, r.task.frame_id) for r in bad] == [("cam01", 99)]
        assert "camera cam01 frame 99" in bad[0].error
    finally:
        pool.close()


def test_a_killed_worker_hands_its_cameras_to_the_others_within_2_s():
    got = Results()
    pool = DetectorPool.of_processes(functools.partial(pool_helpers.SlowDetector, 0.01), 2, got, max_batch=1)
    stop = threading.Event()

    def feed():  # 4 cameras at 30 frames/s
        f = 0
        while not stop.is_set():
            for cam in ("cam01", "cam02", "cam03", "cam04"):
                pool.submit(task(cam, f))
            f += 1
            time.sleep(1 / 30)

    feeder = threading.Thread(target=feed, daemon=True)
    feeder.start()
    try:
        wait_for(lambda: len(got.of("cam01")) > 5, 20, "cam01 detected")
        victim = pool.assignment()["cam01"]
        pid = pool.pids()[victim]
        moved = [c for c, w in pool.assignment().items() if w == victim]
        os.kill(pid, signal.SIGKILL)
        killed = time.monotonic()
        wait_for(lambda: pool.alive_workers() == [1 - victim], 5, "the killed worker noticed")
        for cam in moved:
            wait_for(lambda cam=cam: any(t > killed and r.worker != victim for t, r in got.items
                                         if r.task.camera == cam), 5, f"{cam} detected by another worker")
            first = min(t for t, r in got.items if r.task.camera == cam and t > killed and r.worker != victim)
            assert first - killed < 2.0, f"{cam} came back after {first - killed:.2f} s"
        assert sum(pool.counts.lost.values()) <= 2 * pool.max_inflight  # only what the dead worker held
        # a replacement starts after a second and takes cameras from the other worker
        wait_for(lambda: pool.alive_workers() == [1 - victim, 2], 60, "a replacement worker")
        assert sorted(pool.assignment().values()) == sorted([1 - victim, 1 - victim, 2, 2])
        wait_for(lambda: len({r.worker for _, r in got.items if r.worker == 2}) == 1, 10, "the replacement detecting")
    finally:
        stop.set()
        feeder.join(5)
        pool.close()


def test_a_worker_that_cannot_build_its_detector_is_named():
    with pytest.raises(RuntimeError, match=r"worker 0 .*could not build its detector: FileNotFoundError: model file"):
        DetectorPool.of_processes(functools.partial(pool_helpers.SlowDetector, 0.0, True), 1)


def test_a_full_queue_skips_the_oldest_frames_and_counts_them_per_camera():
    got = Results()
    pool = DetectorPool.in_process(pool_helpers.SlowDetector(0.05), got, max_pending=3)
    try:
        for f in range(10):
            pool.submit(task("cam01", f))
        wait_for(lambda: not pool.busy(), 10, "queue drained")
        done = [r.task.frame_id for r in got.of("cam01")]
        assert pool.counts.skipped["cam01"] == 10 - len(done) and done[-3:] == [7, 8, 9]
    finally:
        pool.close()


def test_the_node_keeps_detecting_every_camera_when_a_worker_is_killed():
    """A detector node over the bus with two worker processes: one SIGKILLed mid-trial, its cameras keep
    getting keypoints from the other and the node's coverage counts what was lost."""
    from gaitcap.acquisition.drivers.simulated import simulated_rig
    from gaitcap.services.bus.session import BusConfig, open_session
    from gaitcap.services.nodes.camera import CameraNode
    from gaitcap.services.nodes.detector import DetectorNode
    from gaitcap.simulator import make_trial

    trial = make_trial("paper", seconds=5.0, cameras=4, people=1, seed=1, fps=30.0)
    bus = BusConfig.free_local(["camera-0", "detector", "sink"], prefix="gaitcap/dk")
    sc, sd, ss = (open_session(bus, n) for n in ("camera-0", "detector", "sink"))
    got = Results()
    sub = ss.declare_subscriber(bus.keys.keypoints(), lambda s: got(SimpleResult(s)))
    pool = DetectorPool.of_processes(functools.partial(pool_helpers.SlowDetector, 0.005), 2, max_batch=2)
    det = DetectorNode(sd, bus, "detector", pool, status_period_s=0.2)
    drivers = simulated_rig(trial, size_px=(32, 24), realtime=True, max_frames=120,
                            render=lambda t, c, f, s: np.zeros((s[1], s[0], 3), np.uint8))
    node = CameraNode(sc, bus, "camera-0", drivers)
    runner = threading.Thread(target=node.run, kwargs={"start_at_ns": time.time_ns() + 300_000_000}, daemon=True)
    try:
        runner.start()
        wait_for(lambda: len(pool.assignment()) == 4 and det.detected > 20, 20, "every camera detected")
        victim = 0
        moved = [c for c, w in pool.assignment().items() if w == victim]
        os.kill(pool.pids()[victim], signal.SIGKILL)
        killed = time.monotonic()
        for cam in moved:
            wait_for(lambda cam=cam: any(t > killed for t, r in got.items if r.task.camera == cam), 5,
                     f"{cam} detected after the kill")
            first = min(t for t, r in got.items if r.task.camera == cam and t > killed)
            assert first - killed < 2.0, f"{cam} came back after {first - killed:.2f} s"
        runner.join(20)
        assert det.wait_idle(10)
        wait_for(lambda: len(pool.alive_workers()) == 2, 60, "the killed worker replaced")
        status = det.status()
        assert status.workers == 2 and status.pool == 2 and set(status.cameras) == set(trial.rig.names)
        for row in status.cameras.values():
            assert row["detected"] + row["lost"] + row["skipped"] + row["failed"] == row["received"], row
    finally:
        sub.undeclare()
        node.close()
        det.close()
        for s in (sc, sd, ss):
            s.close()


class SimpleResult:
    """A keypoints message as the Results collector files it (its camera and frame id)."""

    def __init__(self, sample):
        import json

        msg = json.loads(sample.payload.to_bytes())
        self.task = FrameTask(msg["camera"], msg["frame_id"], msg["timestamp_ns"], 0, b"")


def test_frames_older_than_the_age_limit_are_skipped_not_detected():
    got = Results()
    pool = DetectorPool.in_process(pool_helpers.SlowDetector(0.5), got, max_age_s=0.2)
    try:
        for f in (1, 2, 3):  # 1 and 2 go to the worker at once; 3 waits 0.5 s for it: too old
            pool.submit(task("cam01", f))
        wait_for(lambda: len(got.items) == 2 and not pool.busy(), 10, "the first two detected")
        pool.submit(task("cam01", 4))
        wait_for(lambda: len(got.items) == 3, 10, "a fresh frame detected")
        assert [r.task.frame_id for r in got.of("cam01")] == [1, 2, 4] and pool.counts.skipped["cam01"] == 1
    finally:
        pool.close()


def test_a_live_pool_behind_thins_out_the_same_frame_ids_on_every_camera():
    got = Results()
    pool = DetectorPool.in_process(pool_helpers.SlowDetector(0.005), got, max_age_s=60.0)
    try:
        for f in range(64):
            for cam in ("cam01", "cam02", "cam03"):
                pool.submit(task(cam, f))
        wait_for(lambda: not pool.busy(), 20, "queue drained")
        ids = {cam: {r.task.frame_id for r in got.of(cam)} for cam in ("cam01", "cam02", "cam03")}
        assert len(ids["cam01"]) < 40  # thinned out: far fewer than the 64 frames
        common = ids["cam01"] & ids["cam02"] & ids["cam03"]
        assert len(common) >= 0.8 * max(len(v) for v in ids.values()), ids  # mostly the same frame ids
        assert sum(pool.counts.skipped.values()) == 3 * 64 - sum(len(v) for v in ids.values())
    finally:
        pool.close()


def test_a_pool_shares_the_cores_out_between_its_detectors_interpreter_threads(monkeypatch):
    from gaitcap.acquisition.detectors import pool as pool_module
    from gaitcap.acquisition.detectors.mediapipe import MediaPipeConfig
    from gaitcap.acquisition.detectors.onnx import OnnxConfig

    monkeypatch.setattr(pool_module, "default_workers", lambda: 8)
    assert pool_module.shared_cores(MediaPipeConfig(model="lite"), 4).num_threads == 2
    assert pool_module.shared_cores(MediaPipeConfig(), 8).num_threads == 1
    assert pool_module.shared_cores(MediaPipeConfig(), 16).num_threads == 1
    assert pool_module.shared_cores(MediaPipeConfig(num_threads=3), 8).num_threads == 3  # the user's is kept
    assert pool_module.shared_cores(MediaPipeConfig(), 0).num_threads == 2  # in this process: unchanged
    assert pool_module.shared_cores(OnnxConfig(model_path="m.onnx"), 2).num_threads == 4
