import json
import threading
import time

import numpy as np
from gaitcap.acquisition.detectors.simulated import SimulatedConfig
from gaitcap.acquisition.drivers.simulated import simulated_rig
from gaitcap.reconstruction.skeletons import get_skeleton
from gaitcap.services.bus.session import BusConfig, alive_nodes, open_session
from gaitcap.services.nodes.camera import CameraNode
from gaitcap.services.nodes.detector import DetectorNode
from gaitcap.simulator import make_trial

from .conftest import wait_for


def free_bus(names, prefix="gaitcap/dn"):
    return BusConfig.free_local(names, prefix=prefix)


class Flaky:
    """Two people on even frames, none on odd frames, fails on frame 5, NaN for one joint."""

    skeleton = get_skeleton("coco17")

    def detect(self, image_bgr, *, camera, frame_id, timestamp_ns):
        assert image_bgr.shape == (24, 32, 3)
        if frame_id == 5:
            raise RuntimeError("model hiccup")
        if frame_id % 2:
            return np.zeros((0, 17, 3))
        kp = np.tile([[10.0 + frame_id, 20.0, 0.8]], (2, 17, 1))
        kp[0, 3] = np.nan
        return kp


def _run(detector, trial, frames=8):
    bus = free_bus(["camera-0", "detector", "sink"])
    sc, sd, ss = (open_session(bus, n) for n in ("camera-0", "detector", "sink"))
    got, lock = [], threading.Lock()
    sub = ss.declare_subscriber(bus.keys.keypoints(), lambda s: (lock.acquire(), got.append(json.loads(s.payload.to_bytes())), lock.release()))
    det = DetectorNode(sd, bus, "detector", detector)
    try:
        wait_for(lambda: {"detector"} <= alive_nodes(ss, bus), 10, "detector alive")
        drivers = simulated_rig(trial, size_px=(32, 24), realtime=False, max_frames=frames,
                                render=lambda t, c, f, s: np.zeros((s[1], s[0], 3), np.uint8))
        node = CameraNode(sc, bus, "camera-0", drivers)
        time.sleep(0.3)
        node.run(start_at_ns=time.time_ns())
        assert det.wait_idle(10)
        time.sleep(0.3)
        node.close()
        return det, list(got)
    finally:
        sub.undeclare()
        det.close()
        for s in (sc, sd, ss):
            s.close()


def test_keypoints_schema_people_and_failures():
    trial = make_trial("paper", seconds=5.0, cameras=2, people=1, seed=4, fps=30.0)
    det, got = _run(Flaky(), trial)
    assert det.failed == 2 and det.detected == 14  # frame 5 of both cameras failed
    msg = next(m for m in got if m["camera"] == "cam01" and m["frame_id"] == 2)
    assert set(msg) >= {"camera", "frame_id", "timestamp_ns", "skeleton", "people"}
    assert msg["skeleton"] == "coco17" and np.asarray(msg["people"]).shape == (2, 17, 3)
    assert msg["people"][0][3] == [0, 0, 0] and msg["people"][1][0] == [12.0, 20.0, 0.8]
    assert next(m for m in got if m["frame_id"] == 3)["people"] == []


def test_simulated_detector_reproduces_the_worlds_keypoints():
    trial = make_trial("paper", seconds=5.0, cameras=2, people=1, seed=4, fps=30.0)
    det, got = _run(SimulatedConfig(trial=trial).build(), trial, frames=6)
    assert det.detected == 12 and det.failed == 0
    for m in got:
        c = trial.rig.names.index(m["camera"])
        want = trial.detections.one_person[c, m["frame_id"]]
        if m["people"]:
            ok = want[:, 2] > 0
            np.testing.assert_allclose(np.asarray(m["people"][0])[ok], want[ok], atol=1e-3)


def test_shards_share_the_cameras_and_report_coverage_on_the_bus():
    from gaitcap.services.bus.messages import DetectorStatus
    from gaitcap.services.nodes.detector import CameraSelection

    trial = make_trial("paper", seconds=5.0, cameras=4, people=1, seed=4, fps=30.0)
    bus = free_bus(["camera-0", "detector-0", "detector-1", "sink"], prefix="gaitcap/ds")
    sessions = {n: open_session(bus, n) for n in ("camera-0", "detector-0", "detector-1", "sink")}
    got, statuses, lock = [], {}, threading.Lock()

    def on_kp(s):
        with lock:
            got.append(json.loads(s.payload.to_bytes()))

    def on_status(s):
        msg = DetectorStatus.from_bytes(s.payload.to_bytes())
        with lock:
            statuses[msg.node] = msg

    subs = [sessions["sink"].declare_subscriber(bus.keys.keypoints(), on_kp),
            sessions["sink"].declare_subscriber(bus.keys.detector_status(), on_status)]
    dets = [DetectorNode(sessions[f"detector-{k}"], bus, f"detector-{k}", SimulatedConfig(trial=trial).build(),
                         cameras=CameraSelection(shard=k, shards=2), status_period_s=0.2) for k in (0, 1)]
    try:
        wait_for(lambda: {"detector-0", "detector-1"} <= alive_nodes(sessions["sink"], bus), 10, "detectors alive")
        drivers = simulated_rig(trial, size_px=(32, 24), realtime=False, max_frames=5,
                                render=lambda t, c, f, s: np.zeros((s[1], s[0], 3), np.uint8))
        node = CameraNode(sessions["camera-0"], bus, "camera-0", drivers)
        time.sleep(0.3)
        node.run(start_at_ns=time.time_ns())
        assert all(d.wait_idle(10) for d in dets)
        wait_for(lambda: len(got) == 20, 10, "every camera's 5 frames detected once")
        node.close()
        pairs = [(m["camera"], m["frame_id"]) for m in got]
        assert len(set(pairs)) == 20  # no frame detected twice
        wait_for(lambda: sum(r["detected"] for s in statuses.values() for r in s.cameras.values()) == 20, 5,
                 "coverage of every frame reported")
        cams = [set(statuses[f"detector-{k}"].cameras) for k in (0, 1)]
        assert not cams[0] & cams[1] and cams[0] | cams[1] == set(trial.rig.names)
        row = next(iter(statuses["detector-0"].cameras.values()))
        assert row["received"] == 5 and row["skipped"] == row["lost"] == row["failed"] == 0
        assert 0 <= row["lag_s"] < 5
    finally:
        for s in subs:
            s.undeclare()
        for d in dets:
            d.close()
        for s in sessions.values():
            s.close()
