"""What the API needs from the live system, as small protocols, plus their Zenoh implementation.

The API (HTTP only) never talks to cameras: it asks a :class:`TrialRecorder` to start and stop the
trial's recording and reads camera health and JPEG previews from a :class:`LiveView`. ``BusLink``
(``gaitcap.services.live.bus_link``) implements both over Zenoh.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol


class RecorderUnavailable(RuntimeError):
    """The recorder did not answer (not running, or the bus is down)."""


@dataclass(frozen=True)
class CameraHealth:
    """One camera as seen on the bus: frame rate (Hz), health in words, last frame age (s); ``delivering``:
    frames arrive (a slow camera delivers but is not healthy)."""

    name: str
    fps: float
    healthy: bool
    status: str
    age_s: float
    details: dict = field(default_factory=dict)
    delivering: bool | None = None  # images arrive (perhaps too slowly); None: same as ``healthy``

    @property
    def has_signal(self) -> bool:
        return self.healthy if self.delivering is None else self.delivering


class TrialRecorder(Protocol):
    def start(self, *, trial_id: str, path: str, metadata: dict, calibration_toml: str | None = None) -> None:
        """Begin recording ``trial_id`` into the MCAP at ``path`` with the trial's calibration (TOML text,
        None: none in use; its own field, never inside ``metadata``); RecorderUnavailable on failure."""

    def stop(self, trial_id: str) -> dict:
        """Stop and close the MCAP; returns the recorder's summary (frames, drops, ...)."""


class LiveView(Protocol):
    def cameras(self) -> list[CameraHealth]:
        """Cameras seen recently, sorted by name."""

    def preview(self, camera: str) -> tuple[float, bytes] | None:
        """(receive time s, JPEG bytes) of the newest preview frame of ``camera``, or None."""


class Components(Protocol):
    def nodes(self) -> dict:
        """{node name: :class:`gaitcap.services.live.nodes.NodeState`} of the bus nodes seen."""

    def recorder_status(self) -> dict | None:
        """The recorder's status (``trial_id`` it records, ``queued``, ...), None when it does not answer."""

    def detection(self) -> dict:
        """Live detection coverage per camera and detector node
        (:func:`gaitcap.services.live.detector_coverage.detection_summary`)."""


class BoardGuide(Protocol):
    def watch_board(self, calibration_id: str, board: dict | None) -> None:
        """Have the detector nodes look for ``board`` (None: the default board) while board recording
        ``calibration_id`` runs (:mod:`gaitcap.services.live.board_coverage`)."""

    def unwatch_board(self, calibration_id: str) -> None:
        """Stop looking for the board of ``calibration_id``."""

    def board_coverage(self, calibration_id: str, cameras: list[str]) -> dict | None:
        """Where the board has been seen in ``calibration_id`` so far
        (:func:`gaitcap.services.live.board_coverage.coverage_summary`), None when it is not watched."""


class Link(TrialRecorder, LiveView, Components, BoardGuide, Protocol):
    connected: bool  # False: no recorder can ever answer (Start is refused before a trial is created)

    def close(self) -> None: ...


class SceneControl(Protocol):
    """What simulated cameras show (the demo's Calibrate switches them to a board). Only a simulated stack
    wires one in (``gaitcap serve --sim-scene``: :class:`gaitcap.services.live.sim_scene.BusSceneControl`);
    real cameras have nothing to switch (:class:`NoScene`)."""

    def show(self, scene: str, *, start_ns: int) -> None:
        """Show ``scene`` (walker | board) from ``start_ns`` (wall clock, ns)."""


class NoScene:
    """No simulated cameras: nothing to switch."""

    def show(self, scene: str, *, start_ns: int) -> None:
        return None


class NoLink:
    """No live system attached (the API serves the catalog only; Start answers 503)."""

    connected = False

    def start(self, *, trial_id: str, path: str, metadata: dict, calibration_toml: str | None = None) -> None:
        raise RecorderUnavailable("no recorder is connected to this server (started without the bus)")

    def stop(self, trial_id: str) -> dict:
        raise RecorderUnavailable("no recorder is connected to this server (started without the bus)")

    def cameras(self) -> list[CameraHealth]:
        return []

    def preview(self, camera: str) -> tuple[float, bytes] | None:
        return None

    def nodes(self) -> dict:
        return {}

    def recorder_status(self) -> dict | None:
        return None

    def detection(self) -> dict:
        return {"nodes": {}, "cameras": {}}

    def watch_board(self, calibration_id: str, board: dict | None) -> None:
        return None

    def unwatch_board(self, calibration_id: str) -> None:
        return None

    def board_coverage(self, calibration_id: str, cameras: list[str]) -> dict | None:
        return None

    def close(self) -> None:
        pass
