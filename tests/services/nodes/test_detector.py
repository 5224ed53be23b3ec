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
    det = DetectorNode(sd, bus, "detector", detector, workers=2)
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
        want = trial.detections.keypoints[c, m["frame_id"]]
        if m["people"]:
            ok = want[:, 2] > 0
            np.testing.assert_allclose(np.asarray(m["people"][0])[ok], want[ok], atol=1e-3)
