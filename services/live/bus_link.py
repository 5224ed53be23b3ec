"""The API's link to the live system over Zenoh: the recorder's queryables, camera status, previews.

Implements :class:`gaitcap.services.live.protocols.Link` with ``gaitcap.services.bus.control`` clients on a session of the
``api`` node (peer mode, explicit endpoints; see ``gaitcap.services.bus.session``).
"""

from __future__ import annotations

import logging
import os
import time
from dataclasses import replace

from gaitcap.services.live.board_coverage import BoardViews
from gaitcap.services.live.detector_coverage import DetectorCoverageBoard
from gaitcap.services.live.nodes import NodeBoard
from gaitcap.services.live.protocols import CameraHealth, RecorderUnavailable
from gaitcap.services.processing.quality import QualityCriteria

log = logging.getLogger(__name__)
STALE_S = 3.0  # no status or frame for this long: the camera is reported as "no signal"
# below the sync criteria's frame rate a camera is not healthy (28 Hz for 30 Hz cameras; GAITCAP_MIN_FPS)
MIN_FPS = float(os.environ.get("GAITCAP_MIN_FPS", QualityCriteria().min_fps_at(30.0)))


def camera_health(name: str, status: dict | None, frame_age_s: float | None, now_s: float,
                  min_fps: float = MIN_FPS) -> CameraHealth:
    """Health in words from the camera's latest status message and the age of its newest frame; a
    camera delivering below ``min_fps`` (Hz) is not healthy ("slow")."""
    status = status or {}
    fps = float(status.get("fps") or 0.0)
    status_age = now_s - status.get("time_ns", 0) / 1e9 if status else float("inf")
    age = min(status_age, frame_age_s if frame_age_s is not None else float("inf"))
    health = str(status.get("health", "ok" if frame_age_s is not None else "unknown"))
    if age > STALE_S:
        words, ok = "no signal", False
    elif status.get("error"):
        words, ok = f"error: {status['error']}", False
    elif health != "ok":
        words, ok = health, False
    elif status and fps < min_fps:
        words, ok = f"slow: {fps:.0f} fps (needs {min_fps:.0f})", False
    else:
        words, ok = "ok", True
    details = {k: status.get(k) for k in ("state", "frames", "drops", "ptp_jumps") if k in status}
    delivering = ok or words.startswith("slow")
    return CameraHealth(name, fps, ok, words, age if age != float("inf") else -1.0, details, delivering)


class BusLink:
    connected = True

    def __init__(self, bus, *, node: str | None = "api", timeout_s: float = 10.0) -> None:
        from gaitcap.services.bus.control import CameraStatusBoard, PreviewFrames, RecorderClient
        from gaitcap.services.bus.session import declare_alive, open_session

        self.bus = bus
        self.session = open_session(bus, node)
        self._alive = declare_alive(self.session, bus, node) if node else None
        self.recorder = RecorderClient(self.session, bus.keys, timeout_s=timeout_s)
        self._recorder_status = RecorderClient(self.session, bus.keys, timeout_s=1.0)
        self.status_board = CameraStatusBoard(self.session, bus.keys)
        self.previews = PreviewFrames(self.session, bus.keys)
        self.node_board = NodeBoard(self.session, bus)
        self.coverage = DetectorCoverageBoard(self.session, bus.keys)
        self.board_views = BoardViews(self.session, bus.keys)

    def start(self, *, trial_id: str, path: str, metadata: dict, calibration_toml: str | None = None) -> None:
        from gaitcap.services.bus.control import RecorderError

        try:
            self.recorder.start(trial_id=trial_id, path=path, metadata=metadata, calibration_toml=calibration_toml)
        except RecorderError as exc:
            raise RecorderUnavailable(str(exc)) from None

    def stop(self, trial_id: str) -> dict:
        from gaitcap.services.bus.control import RecorderError

        try:
            return self.recorder.stop(trial_id).summary or {}
        except RecorderError as exc:
            raise RecorderUnavailable(str(exc)) from None

    def cameras(self) -> list[CameraHealth]:
        now = time.time()
        statuses = self.status_board.snapshot()
        frames = self.previews.latest()
        names = sorted(set(statuses) | set(frames))
        nodes = self.node_board.snapshot()
        out = []
        for n in names:
            cam = camera_health(n, statuses.get(n), now - frames[n].received_s if n in frames else None, now)
            node = nodes.get(str((statuses.get(n) or {}).get("node")))
            if node is not None and not node.alive:  # its process died: known at once, not after STALE_S
                cam = replace(cam, healthy=False, status=f"no signal (camera node {node.name} down)", delivering=False)
            out.append(cam)
        return out

    def nodes(self) -> dict:
        return self.node_board.snapshot()

    def recorder_status(self) -> dict | None:
        from gaitcap.services.bus.control import RecorderError

        try:
            reply = self._recorder_status.status()
        except RecorderError:
            return None
        return {"trial_id": reply.trial_id, "recording": reply.recording, "queued": reply.queued}

    def detection(self) -> dict:
        return self.coverage.snapshot()

    def watch_board(self, calibration_id: str, board: dict | None) -> None:
        self.board_views.watch(calibration_id, board)

    def unwatch_board(self, calibration_id: str) -> None:
        self.board_views.unwatch(calibration_id)

    def board_coverage(self, calibration_id: str, cameras: list[str]) -> dict | None:
        return self.board_views.coverage(calibration_id, cameras)

    def preview(self, camera: str) -> tuple[float, bytes] | None:
        frame = self.previews.latest().get(camera)
        return None if frame is None else (frame.received_s, frame.jpeg)

    def close(self) -> None:
        for item in (self.status_board, self.previews, self.node_board, self.coverage, self.board_views):
            try:
                item.close()
            except Exception:  # closing during shutdown: nothing left to do
                log.debug("closing %s failed", item, exc_info=True)
        if self._alive is not None:
            self._alive.undeclare()
        self.session.close()
