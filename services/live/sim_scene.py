"""The API's scene control for a simulated stack: tells the simulated camera nodes
(:mod:`gaitcap.services.nodes.sim_scene`) what to show, over the bus. Wired in by ``gaitcap serve
--sim-scene`` (the demo stack does); the API knows only :class:`gaitcap.services.live.protocols.SceneControl`.
"""

from __future__ import annotations

from gaitcap.services.bus.messages import CameraScene


class BusSceneControl:
    """Publishes :class:`gaitcap.services.bus.messages.CameraScene` on ``<prefix>/camera/scene`` with the
    session of the API's bus link (closed with it)."""

    def __init__(self, session, bus) -> None:
        self.session, self.key = session, bus.keys.camera_scene

    def show(self, scene: str, *, start_ns: int) -> None:
        """Simulated cameras show ``scene`` (walker | board) from ``start_ns`` (wall clock, ns)."""
        self.session.put(self.key, CameraScene(scene, int(start_ns)).to_bytes())
