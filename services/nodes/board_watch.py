"""Board watcher: while a board recording runs, look for the board in the frames of a detector node's
cameras and publish what was found, so the clinic page can show where the board has been seen.

The API puts a :class:`~gaitcap.services.bus.messages.BoardWatch` on ``<prefix>/board/watch`` when a
board recording starts (the board, the slot length) and another, inactive, at Stop. Meanwhile the
watcher takes the first frame of each camera in every slot of ``slot_s`` s of camera time (the same
slots on every node: the views of one slot are of one moment), looks for the board in them in one
thread and publishes a :class:`~gaitcap.services.bus.messages.BoardView` per frame looked at on
``<prefix>/board/views/<cam>`` (corners found, or none). When looking falls behind, whole slots are
skipped (counted), never one camera of a slot, so the pairs of cameras that saw the board together stay
true; the looking thread runs at a lower priority (``NICE``): on a busy host it yields the CPU to the
cameras, the recorder and the keypoints, and looks at fewer frames. Without a watch the image callback
returns at once. It runs inside ``gaitcap node detector`` (the node that already receives its cameras'
frames); recording and keypoints are not touched.
"""

from __future__ import annotations

import logging
import os
import threading

import numpy as np
from gaitcap.services.bus.messages import BoardView, BoardWatch, ImageFrame
from gaitcap.services.bus.session import BusConfig
from gaitcap.services.nodes.detector import CameraSelection

log = logging.getLogger(__name__)
KEEP_SLOTS = 2  # slots waiting to be looked at; an older one is skipped
NICE = 10  # the looking thread's niceness above its process's: spare CPU only (cameras, the recorder and the
# keypoints come first; the simulated cameras run at nice 5), about 80 ms a 576 x 360 frame on the 2 cores


def board_of(watch: BoardWatch):
    """The board object (``acquisition.boards``) a watch asks for; ValueError naming the field."""
    from gaitcap.acquisition.boards.detection import BoardConfig, make_board
    from gaitcap.acquisition.boards.file import board_from_dict

    config = BoardConfig() if watch.board is None else board_from_dict(
        {"board": watch.board}, source=f"board watch {watch.calibration_id} board")
    return make_board(config)


class SlotQueue:
    """The frames waiting to be looked at: the first frame of each camera in each slot, at most ``keep``
    slots; when a newer slot would exceed it, the oldest slot is dropped whole (``skipped`` counts them).
    Not thread-safe: the watcher holds its lock."""

    def __init__(self, keep: int = KEEP_SLOTS) -> None:
        self.keep, self.skipped = keep, 0
        self.pending: dict[int, dict[str, object]] = {}  # slot -> camera -> its first frame in the slot
        self._last: dict[str, int] = {}

    def add(self, camera: str, slot: int, frame) -> bool:
        """Keep ``frame`` when it is ``camera``'s first in a slot later than its last one kept."""
        if slot <= self._last.get(camera, -1):
            return False
        self._last[camera] = slot
        self.pending.setdefault(slot, {})[camera] = frame
        while len(self.pending) > self.keep:
            del self.pending[min(self.pending)]
            self.skipped += 1
        return True

    def pop_oldest(self) -> dict[str, object]:
        return self.pending.pop(min(self.pending))

    def clear(self) -> None:
        self.pending.clear()
        self._last.clear()


class BoardWatcher:
    """Looks for the board in the bus frames of ``cameras`` while a board watch is active, until :meth:`close`."""

    def __init__(self, session, bus: BusConfig, *, cameras: CameraSelection | None = None) -> None:
        self.session, self.bus = session, bus
        self.cameras = cameras or CameraSelection()
        self.looked = 0
        self._cond = threading.Condition()
        self._watch: BoardWatch | None = None
        self._board = None
        self._slots = SlotQueue()
        self._pubs: dict[str, object] = {}
        self._closed = False
        keys = [bus.keys.image(c) for c in self.cameras.names] or [bus.keys.image()]
        self._subs = [session.declare_subscriber(bus.keys.board_watch, self._on_watch),
                      *(session.declare_subscriber(k, self._on_image) for k in keys)]
        self._thread = threading.Thread(target=self._loop, daemon=True, name="board-watch")
        self._thread.start()

    @property
    def watching(self) -> str | None:
        """The calibration id of the board recording watched now, or None."""
        watch = self._watch
        return watch.calibration_id if watch is not None else None

    def _on_watch(self, sample) -> None:
        try:
            watch = BoardWatch.from_bytes(sample.payload.to_bytes())
            if watch == self._watch:
                return  # the same watch put again (the API does while the page reads the coverage)
            board = board_of(watch) if watch.active else None
        except ValueError as exc:
            log.warning("board watch refused: %s", exc)
            return
        with self._cond:
            if watch.active:
                if self.watching != watch.calibration_id:
                    self._slots = SlotQueue()
                    log.info("looking for the board (%s) of board recording %s", board.config.describe(),
                             watch.calibration_id)
                self._watch, self._board = watch, board
            elif self.watching == watch.calibration_id:
                log.info("board recording %s over: %d frames looked at, %d slots skipped", watch.calibration_id,
                         self.looked, self._slots.skipped)
                self._watch, self._board = None, None
                self._slots.clear()
            self._cond.notify_all()

    def _on_image(self, sample) -> None:
        watch = self._watch
        if watch is None:
            return
        try:
            frame = self.cameras.frame_of(self.bus.keys, sample)
        except ValueError as exc:
            log.debug("frame on %s not looked at: %s", sample.key_expr, exc)
            return
        if frame is None:
            return
        camera = frame.camera
        slot = frame.timestamp_ns // int(watch.slot_s * 1e9)
        with self._cond:
            if self._watch is watch and self._slots.add(camera, slot, frame):
                self._cond.notify_all()

    def _next(self) -> tuple[BoardWatch, object, dict[str, ImageFrame]] | None:
        """The oldest waiting slot once a later one has begun, or once no later one began for a slot's
        time (the last slot before Stop), with its watch and board; None once closed."""
        with self._cond:
            while not self._closed:
                pending = self._slots.pending
                if len(pending) > 1:
                    break
                if pending:  # (a pending slot implies a watch: both are cleared together)
                    if not self._cond.wait(self._watch.slot_s) and len(self._slots.pending) == 1:
                        break
                    continue
                self._cond.wait(1.0)
            if self._closed:
                return None
            return self._watch, self._board, self._slots.pop_oldest()

    def _loop(self) -> None:
        try:  # Linux: a thread has its own niceness
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), min(19, os.getpriority(os.PRIO_PROCESS, 0) + NICE))
        except (AttributeError, OSError):
            log.debug("board watcher: niceness not set", exc_info=True)
        while (item := self._next()) is not None:
            watch, board, frames = item
            for camera, frame in sorted(frames.items()):
                try:
                    self._look(watch, board, frame)
                except Exception:  # one bad frame (or the bus closing) must not end the watcher
                    log.warning("camera %s frame %d: board not looked for", camera, frame.frame_id, exc_info=True)

    def _look(self, watch: BoardWatch, board, frame: ImageFrame) -> None:
        image = frame.image()
        corners = board.find(image).corners
        found = [] if corners is None else np.round(corners[np.isfinite(corners).all(axis=1)], 2).tolist()
        view = BoardView(calibration_id=watch.calibration_id, camera=frame.camera, frame_id=frame.frame_id,
                         timestamp_ns=frame.timestamp_ns, width_px=int(image.shape[1]), height_px=int(image.shape[0]),
                         corners=found)
        if frame.camera not in self._pubs:
            self._pubs[frame.camera] = self.session.declare_publisher(self.bus.keys.board_views(frame.camera))
        self._pubs[frame.camera].put(view.to_bytes())
        self.looked += 1

    def close(self) -> None:
        for sub in self._subs:
            sub.undeclare()
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        self._thread.join(timeout=5)
