"""The simulated cameras' scene switch, the two plug-ins the simulated stack wires in, over a real Zenoh
bus: the API side (:class:`BusSceneControl`) publishes, the camera side (:func:`attach_board_scene`)
switches every simulated camera of the node to the board clip and back; other drivers are left alone."""

import time

import numpy as np
from gaitcap.acquisition.drivers.simulated import simulated_rig
from gaitcap.services.bus.session import BusConfig, open_session
from gaitcap.services.live.sim_scene import BusSceneControl
from gaitcap.services.nodes.sim_scene import attach_board_scene
from gaitcap.simulator import make_trial

PERIOD_NS = 33_333_333
CAMERA_START_NS = 10**18


def _shown(control: BusSceneControl, scene: str, start_ns: int, seen, timeout_s: float = 20.0) -> bool:
    """Publish ``scene`` until ``seen()`` (the two fresh sessions may not be connected yet when it is first
    put; repeating the same scene and start changes nothing once it has arrived)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        control.show(scene, start_ns=start_ns)
        for _ in range(5):
            time.sleep(0.05)
            if seen():
                return True
    return False


class RealCamera:
    name = "flir01"


def test_the_api_switches_the_simulated_cameras_to_the_board_and_back():
    trial = make_trial("paper", seconds=5.0, cameras=2, people=1, seed=2, fps=30.0)
    drivers = simulated_rig(trial, size_px=(48, 32), realtime=False, max_frames=3,
                            render=lambda t, c, f, s: np.zeros((s[1], s[0], 3), np.uint8))
    bus = BusConfig.free_local(["camera-0", "api"], prefix="gaitcap/scene")
    cam_session, api_session = open_session(bus, "camera-0"), open_session(bus, "api")
    try:
        sub = attach_board_scene(cam_session, bus, [*drivers, RealCamera()], "short")
        assert sub is not None and not hasattr(RealCamera, "scene")
        switch = drivers[0].scene[0]
        assert all(d.scene[0] is switch for d in drivers)  # every camera changes at the same frame id

        def board_index():
            return switch.board_index(7, camera_start_ns=CAMERA_START_NS, period_ns=PERIOD_NS)

        assert board_index() is None  # the walker until told otherwise
        control = BusSceneControl(api_session, bus)
        board_from_frame_2 = CAMERA_START_NS + 2 * PERIOD_NS
        assert _shown(control, "board", board_from_frame_2, lambda: board_index() == 5), "the board was not shown"
        assert _shown(control, "walker", CAMERA_START_NS, lambda: board_index() is None), "the walker stayed away"
        sub.undeclare()
    finally:
        api_session.close()
        cam_session.close()
    assert attach_board_scene(None, bus, [RealCamera()], "short") is None  # nothing simulated: no subscriber
