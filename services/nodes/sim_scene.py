"""The simulated cameras' scene switch on the bus: what the demo's Calibrate button needs from them.

Lives with the simulator, not in the camera node: ``gaitcap node camera --source simulated`` wires it in
beside :class:`gaitcap.services.nodes.camera.CameraNode`, which knows nothing about scenes. The API's
side is :class:`gaitcap.services.live.sim_scene.BusSceneControl`.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Sequence

from gaitcap.acquisition.drivers.base import CameraDriver
from gaitcap.acquisition.drivers.simulated import SimulatedCamera
from gaitcap.services.bus.messages import CameraScene
from gaitcap.services.bus.session import BusConfig
from gaitcap.simulator.board_scene import BoardScene, SceneSwitch, board_scene_config

log = logging.getLogger(__name__)


def attach_board_scene(session, bus: BusConfig, drivers: Sequence[CameraDriver], clip: str = "short"):
    """Let simulated cameras show a calibration board on request (``<prefix>/camera/scene``,
    :class:`gaitcap.services.bus.messages.CameraScene`), the board clip named ``clip`` in
    :data:`gaitcap.simulator.board_scene.BOARD_SCENES`. Other drivers are left alone. Returns the
    subscriber (None when no driver is simulated)."""
    config = board_scene_config(clip)
    sims = [d for d in drivers if isinstance(d, SimulatedCamera)]
    if not sims:
        return None
    switch, board = SceneSwitch(), BoardScene(sims[0].trial.rig, config)
    for d in sims:
        d.scene = (switch, board)

    def on_scene(sample) -> None:
        try:
            msg = CameraScene.from_bytes(sample.payload.to_bytes())
            switch.set(msg.scene, msg.start_ns)
            if msg.scene == "board":  # set the renderers up now, not in the cameras' frame loops
                threading.Thread(target=lambda: [board.prepare(d.name, d.size_px) for d in sims],
                                 name="board-renderers", daemon=True).start()
        except ValueError as exc:
            log.warning("ignoring a scene message: %s", exc)

    return session.declare_subscriber(bus.keys.camera_scene, on_scene)
