"""The API's view of the cameras on the bus: a camera whose node process is down is reported at once,
not only once its last status has gone stale."""

import time
from types import SimpleNamespace

from gaitcap.services.live.bus_link import BusLink
from gaitcap.services.live.nodes import NodeState


def _link(statuses, frames, nodes):
    link = BusLink.__new__(BusLink)  # no bus session: the boards stand in for what the bus delivered
    link.status_board = SimpleNamespace(snapshot=lambda: statuses)
    link.previews = SimpleNamespace(latest=lambda: frames)
    link.node_board = SimpleNamespace(snapshot=lambda: nodes)
    return link


def test_a_camera_whose_node_is_down_has_no_signal_at_once():
    now = time.time()
    status = {"fps": 30.0, "time_ns": time.time_ns(), "health": "ok", "frames": 90}
    statuses = {"cam01": {**status, "node": "camera-0"}, "cam02": {**status, "node": "camera-1"}}
    frames = {c: SimpleNamespace(received_s=now) for c in statuses}
    nodes = {"camera-0": NodeState("camera-0", True, now - 60, False),
             "camera-1": NodeState("camera-1", False, now, True)}
    got = {c.name: c for c in _link(statuses, frames, nodes).cameras()}
    assert got["cam01"].healthy and got["cam01"].status == "ok" and got["cam01"].has_signal
    down = got["cam02"]
    assert not down.healthy and not down.has_signal and down.fps == 30.0
    assert down.status == "no signal (camera node camera-1 down)" and down.details == {"frames": 90}
