"""A simulated calibration recording: the board carried through the synthetic room, rendered for every
camera and written frame by frame as a trial MCAP (JPEG frames, synchronised frame ids), as the recorder
writes one; and the room's true calibration, at the rendered resolution, to compare against.

The board lies still on the floor for the first ``floor_frames`` frames (the world frame), is laid down
again at ``floor_spots_mm`` (the floor plane), then is shown to each camera up close and carried through
the middle of the room. Frames are rendered and encoded in threads (OpenCV releases the GIL) and
written as they come, so memory stays small whatever the length.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from gaitcap.acquisition.boards.detection import BoardConfig, make_board
from gaitcap.acquisition.encoding import encode_jpeg
from gaitcap.reconstruction.camera import Rig
from gaitcap.simulator.board import (
    FLOOR_SPOTS_MM,
    BoardMotion,
    add_jpeg_frame,
    board_trajectory,
    scaled_rig,
)
from gaitcap.simulator.board_render import BoardRenderer, camera_at
from gaitcap.simulator.room import build_rig

log = logging.getLogger(__name__)

START_NS = 1_700_000_000_000_000_000


@dataclass(frozen=True)
class BoardClipConfig:
    """What to simulate.

    Attributes:
        board: the board filmed.
        frames: frames in the recording (at ``fps``), floor frames included.
        fps: frame rate, frames/s.
        scale: image size as a fraction of the cameras' 1920 x 1200 px.
        cameras: the first this many cameras of the synthetic 10-camera room (2-10).
        floor_frames: frames with the board still on the floor at the world origin.
        floor_spots_mm: (x, y) floor spots where the board is laid down again afterwards (for
            floor_frames // 2 frames each).
        jpeg_quality: JPEG quality of the recorded frames.
        seed: random seed of the board's motion, the room and the image noise.
    """

    board: BoardConfig = field(default_factory=BoardConfig)
    frames: int = 600
    fps: float = 10.0
    scale: float = 1.0
    cameras: int = 10
    floor_frames: int = 20
    floor_spots_mm: tuple[tuple[float, float], ...] = FLOOR_SPOTS_MM
    jpeg_quality: int = 95
    seed: int = 0

    def __post_init__(self) -> None:
        if not 0.1 <= self.scale <= 1.0:
            raise ValueError(f"scale: must lie in [0.1, 1], got {self.scale}")
        on_floor = self.floor_frames + max(self.floor_frames // 2, 1) * len(self.floor_spots_mm)
        if self.floor_frames < 1 or self.frames <= on_floor:
            raise ValueError(f"frames ({self.frames}): must exceed the {on_floor} frames the board lies on the floor "
                             f"(floor_frames {self.floor_frames} >= 1 at the origin, half as many at each other spot)")
        if not 2 <= self.cameras <= 10:
            raise ValueError(f"cameras: the synthetic room holds 2-10 cameras, got {self.cameras}")

    def motion(self) -> BoardMotion:
        return BoardMotion(n_frames=self.frames, fps=self.fps, floor_frames=self.floor_frames,
                           floor_spots_mm=self.floor_spots_mm, seed=self.seed)


def write_board_clip(
    path: str | os.PathLike, config: BoardClipConfig = BoardClipConfig(), *,
    progress: Callable[[int, int], None] | None = None, workers: int | None = None,
) -> tuple[Path, Rig]:
    """Render and write the recording to ``path`` (.mcap); returns it and the true rig at the rendered
    size. On any error no file is left behind."""
    from gaitcap.acquisition.recording.writer import TrialWriter

    rig = build_rig(10, seed=config.seed)
    rig = rig.subset(list(rig.names[: config.cameras]))
    board = make_board(config.board)
    rot, tvec = board_trajectory(board.geometry, config.motion(), rig)
    renderers = [BoardRenderer(cam, board, size_px=camera_at(cam, config.scale).size_px) for cam in rig]
    rngs = [np.random.default_rng([config.seed, c]) for c in range(len(rig))]
    writer = TrialWriter(path)
    try:
        writer.start(metadata={"kind": "calibration", "synthetic": True, "board": board.geometry.name},
                     time_ns=START_NS)
        with ThreadPoolExecutor(max_workers=workers or min(os.cpu_count() or 1, 8)) as pool:
            for i in range(config.frames):
                stamp = START_NS + int(round(i * 1e9 / config.fps))

                def frame(c: int, i: int = i) -> bytes:
                    img = renderers[c].render(rot[i], tvec[i], rngs[c])
                    return encode_jpeg(img, quality=config.jpeg_quality)

                for cam, jpeg in zip(rig.names, pool.map(frame, range(len(rig))), strict=True):
                    add_jpeg_frame(writer, cam, jpeg, frame_id=i, stamp_ns=stamp)
                if progress is not None:
                    progress(i + 1, config.frames)
        out = writer.finish({"frames": config.frames, "cameras": list(rig.names)})
    except BaseException:
        writer.abort()
        writer.part_path.unlink(missing_ok=True)  # synthetic: nothing worth recovering
        raise
    log.info("wrote %s: %d frames x %d cameras", out, config.frames, len(rig))
    return out, scaled_rig(rig, config.scale)
