import json
import threading
import time

import numpy as np
import pytest
from gaitcap.acquisition.drivers.simulated import simulated_rig
from gaitcap.acquisition.encoding import parse_image_message
from gaitcap.services.bus.control import CameraStatusBoard, PreviewFrames
from gaitcap.services.bus.session import BusConfig, alive_nodes, open_session
from gaitcap.services.nodes.camera import CameraNode
from gaitcap.simulator import make_trial

from .conftest import wait_for


def free_bus(names, prefix="gaitcap/cn"):
    return BusConfig.free_local(names, prefix=prefix)


class Broken:
    """A driver that fails after two frames (a camera unplugged)."""

    def __init__(self, inner):
        self.inner, self.name = inner, inner.name

    def start(self, at_ns=None):
        self.inner.start(at_ns)

    def frames(self):
        for i, f in enumerate(self.inner.frames()):
            if i == 2:
                raise OSError("link down")
            yield f

    def stop(self):
        self.inner.stop()

    def status(self):
        return self.inner.status()


def test_frames_status_preview_and_a_failing_camera():
    trial = make_trial("paper", seconds=5.0, cameras=3, people=1, seed=2, fps=30.0)
    bus = free_bus(["camera-0", "viewer"])
    sc, sv = open_session(bus, "camera-0"), open_session(bus, "viewer")
    got = []
    lock = threading.Lock()

    def on_frame(sample):
        with lock:
            got.append((str(sample.key_expr), sample.payload.to_bytes(), json.loads(sample.attachment.to_bytes())))

    sub = sv.declare_subscriber(bus.keys.image(), on_frame)
    board = CameraStatusBoard(sv, bus.keys)
    preview = PreviewFrames(sv, bus.keys)
    try:
        drivers = simulated_rig(trial, size_px=(48, 32), realtime=True, max_frames=12,
                                render=lambda t, c, f, s: np.full((s[1], s[0], 3), 40 * c, np.uint8))
        drivers[2] = Broken(drivers[2])
        node = CameraNode(sc, bus, "camera-0", drivers, status_interval_s=0.1)
        wait_for(lambda: "camera-0" in alive_nodes(sv, bus), 10, "camera-0 alive")
        time.sleep(0.2)
        published = node.run(start_at_ns=time.time_ns() + 100_000_000)
        assert published == {"cam01": 12, "cam02": 12, "cam03": 2}
        time.sleep(0.3)
        with lock:
            frames = list(got)
        per_cam, lateness = {}, []
        for key, payload, att in frames:
            msg = parse_image_message(payload)
            assert key == bus.keys.image(msg.camera) and "timestamp_ns" not in att  # one timestamp: the protobuf's
            lateness.append(att["sent_ns"] - msg.timestamp_ns)
            per_cam.setdefault(msg.camera, []).append(att["frame_id"])
        assert min(lateness) >= 0 and np.median(lateness) < 0.2e9  # paced: never early, not far behind
        assert per_cam["cam01"] == list(range(12)) and per_cam["cam03"] == [0, 1]
        status = board.snapshot()
        assert status["cam03"]["health"] == "error" and "link down" in status["cam03"]["error"]
        assert status["cam01"]["frames"] == 12 and status["cam01"]["node"] == "camera-0"
        latest = preview.latest()
        assert latest["cam02"].frame_id == 11 and latest["cam02"].jpeg[:2] == b"\xff\xd8"
        node.close()
    finally:
        sub.undeclare()
        board.close()
        preview.close()
        sc.close()
        sv.close()


def test_rejects_duplicate_or_no_cameras():
    trial = make_trial("paper", seconds=5.0, cameras=2, people=1, seed=2, fps=30.0)
    bus = free_bus(["camera-0"])
    s = open_session(bus, "camera-0")
    try:
        d = simulated_rig(trial, size_px=(8, 8), render=lambda *a: None)
        with pytest.raises(ValueError, match="duplicate"):
            CameraNode(s, bus, "camera-0", [d[0], d[0]])
        with pytest.raises(ValueError, match="no cameras"):
            CameraNode(s, bus, "camera-0", [])
    finally:
        s.close()
