"""A calibration board shown by the live simulated cameras instead of the walker.

:class:`SceneSwitch` holds what the cameras show (``walker`` or ``board``) and from when; every camera
asks it per frame id, so all cameras that share a start time switch at the same frame id and show the
same board pose at the same frame id. :class:`BoardScene` renders the board clip of
:mod:`gaitcap.simulator.board` (it starts with the board lying on the floor: the world frame) frame
by frame for each camera at the camera's image size (a camera's pixel rays are set up once, on first
use or :meth:`BoardScene.prepare`); the clip loops. Two clips are named in :data:`BOARD_SCENES`:
``short`` (6 s, the default: a quick look in a demo) and ``full`` (60 s, with the floor spots and the
close-ups that a calibration meeting its accuracy targets needs).
"""

from __future__ import annotations

import logging
import math
import threading
from dataclasses import dataclass

import cv2
import numpy as np
from gaitcap.acquisition.boards.detection import BoardConfig, make_board
from gaitcap.reconstruction.camera import Rig
from gaitcap.simulator.board import FLOOR_SPOTS_MM, BoardMotion, board_trajectory
from gaitcap.simulator.board_render import BoardRenderer

log = logging.getLogger(__name__)
SCENES = ("walker", "board")


@dataclass(frozen=True)
class BoardSceneConfig:
    """The board clip (``motion.n_frames`` frames, ``motion.floor_frames`` of them on the floor first),
    looped. The default is short (6 s at 10 frames/s): a slow single turn through the middle of the
    room, so that neighbouring cameras of a small rig share views."""

    board: BoardConfig = BoardConfig()
    motion: BoardMotion = BoardMotion(n_frames=60, floor_frames=3, tour_fraction=0.3, turns=1.0,
                                      max_tilt_deg=20.0, upside_down_fraction=0.0, seed=3)


BOARD_SCENES: dict[str, BoardSceneConfig] = {
    "short": BoardSceneConfig(),
    "full": BoardSceneConfig(motion=BoardMotion(n_frames=600, floor_frames=20, floor_spots_mm=FLOOR_SPOTS_MM)),
}


def board_scene_config(name: str) -> BoardSceneConfig:
    """The board clip called ``name`` in :data:`BOARD_SCENES` (ValueError naming the choices)."""
    if name not in BOARD_SCENES:
        raise ValueError(f"board clip {name!r} is unknown; choose one of {sorted(BOARD_SCENES)}")
    return BOARD_SCENES[name]


class SceneSwitch:
    """Thread-safe: which scene the cameras show from which wall time (ns)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._scene, self._start_ns = "walker", 0

    def set(self, scene: str, start_ns: int) -> None:
        if scene not in SCENES:
            raise ValueError(f"scene: {scene!r} is not one of {list(SCENES)}")
        with self._lock:
            self._scene, self._start_ns = scene, int(start_ns)
        log.info("cameras show the %s from %d ns", scene, start_ns)

    def board_index(self, frame_id: int, *, camera_start_ns: int, period_ns: int) -> int | None:
        """Index into the board clip of ``frame_id`` (frames since the switch), or None: the walker."""
        with self._lock:
            scene, start_ns = self._scene, self._start_ns
        if scene != "board":
            return None
        first = max(0, math.ceil((start_ns - camera_start_ns) / period_ns))
        return None if frame_id < first else frame_id - first


class BoardScene:
    """Renders the board clip seen by each camera of ``rig`` (at any image size: the camera's sensor
    image resized)."""

    def __init__(self, rig: Rig, config: BoardSceneConfig = BoardSceneConfig()) -> None:
        self.rig, self.config = rig, config
        self.board = make_board(config.board)
        self.rot, self.tvec = board_trajectory(self.board.geometry, config.motion, rig)
        self._renderers: dict[tuple[str, tuple[int, int]], tuple[BoardRenderer, np.random.Generator]] = {}
        self._lock = threading.Lock()

    def __len__(self) -> int:
        return len(self.rot)

    def prepare(self, camera: str, size_px: tuple[int, int]) -> tuple[BoardRenderer, np.random.Generator]:
        """The renderer of ``camera`` at ``size_px`` (set up on first use: about a second)."""
        key = (camera, (int(size_px[0]), int(size_px[1])))
        with self._lock:
            if key not in self._renderers:
                index = self.rig.index_of([camera])[0]
                renderer = BoardRenderer(self.rig[camera], self.board, size_px=key[1])
                self._renderers[key] = renderer, np.random.default_rng([self.config.motion.seed, index])
            return self._renderers[key]

    def render_gray(self, camera: str, index: int, size_px: tuple[int, int]) -> np.ndarray:
        """Grey image (H, W) uint8 of clip frame ``index`` (looped) seen by ``camera``."""
        renderer, rng = self.prepare(camera, size_px)
        k = index % len(self.rot)
        return renderer.render(self.rot[k], self.tvec[k], rng)

    def render(self, camera: str, index: int, size_px: tuple[int, int]) -> np.ndarray:
        """BGR image (H, W, 3) uint8 of clip frame ``index`` (looped)."""
        return cv2.cvtColor(self.render_gray(camera, index, size_px), cv2.COLOR_GRAY2BGR)
