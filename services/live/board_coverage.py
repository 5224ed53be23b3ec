"""The board recording's live coverage, as ``GET /calibrations/record/coverage`` reports it: the API asks
the detector nodes' board watchers to look for the board (:class:`gaitcap.services.bus.messages.BoardWatch`
on ``<prefix>/board/watch``) and keeps the views they report (:class:`BoardView` on
``<prefix>/board/views/<cam>``) as image cells per camera and frame
(:func:`gaitcap.reconstruction.calibration.coverage.board_cells`); :func:`coverage_summary` counts them
(:func:`~gaitcap.reconstruction.calibration.coverage.board_coverage`) and says where to move the board.
"""

from __future__ import annotations

import collections
import logging
import threading
import time

from gaitcap.reconstruction.calibration.coverage import GRID, BoardSighting, board_cells, board_coverage
from gaitcap.services.bus.control import named_by_key
from gaitcap.services.bus.messages import BoardView, BoardWatch

log = logging.getLogger(__name__)
SLOT_S = 0.5  # one frame per camera and half second of camera time is looked at
REWATCH_S = 2.0  # the watch is put again this often while coverage is read (a detector node restarted)


def coverage_summary(sightings: list[BoardSighting], looked: dict[str, int], *, cameras: list[str],
                     grid: int = GRID, slot_s: float = SLOT_S) -> dict:
    """``board_coverage(...).to_dict()`` of ``cameras`` (and of every camera that reported a view) with,
    per camera, ``looked``: frames looked at for the board; views in one slot (``slot_s`` s) are one moment.
    The advice starts by naming cameras whose frames nobody looked at (no detector node serves them)."""
    names = sorted(set(cameras) | set(looked))
    cov = board_coverage(sightings, cameras=names, grid=grid, together_ns=int(slot_s * 1e9 / 2))
    out = cov.to_dict()
    for cam in out["cameras"]:
        cam["looked"] = looked.get(cam["name"], 0)
    unseen = [n for n in names if not looked.get(n)]
    if unseen:
        words = ("no frame has been looked at for the board yet" if len(unseen) == len(names) else
                 f"{', '.join(unseen)}: no frame looked at for the board yet")
        out["advice"].insert(0, f"{words} (the detector nodes look about every {slot_s:g} s)")
    out["slot_s"] = slot_s
    return out


class BoardViews:
    """Puts the board watch and keeps the views of the board recording watched (thread-safe)."""

    def __init__(self, session, keys, *, slot_s: float = SLOT_S) -> None:
        self.slot_s = slot_s
        self._lock = threading.Lock()
        self._watch: BoardWatch | None = None
        self._active = False  # the watch is on (put again while read)
        self._put_s = 0.0
        self._sightings: list[BoardSighting] = []
        self._looked: collections.Counter = collections.Counter()
        self._pub = session.declare_publisher(keys.board_watch)
        self._sub = session.declare_subscriber(
            keys.board_views(), named_by_key(BoardView, self._keep, field="camera", name_of=keys.node_of))

    def _put(self, watch: BoardWatch) -> None:  # (under the lock: a watch is never put after its end)
        self._put_s = time.monotonic()
        try:
            self._pub.put(watch.to_bytes())
        except Exception:  # the bus closing: the recording goes on; the coverage says no frame was looked at
            log.warning("board watch of %s not put", watch.calibration_id, exc_info=True)

    def watch(self, calibration_id: str, board: dict | None) -> None:
        """Start looking for ``board`` (a board file's ``[board]`` fields; None: the default board)."""
        watch = BoardWatch(calibration_id=calibration_id, active=True, board=board, slot_s=self.slot_s)
        with self._lock:
            self._watch, self._sightings, self._looked = watch, [], collections.Counter()
            self._active = True
            self._put(watch)

    def unwatch(self, calibration_id: str) -> None:
        """Stop looking (the views stay readable until the next watch)."""
        with self._lock:
            self._active = False
            self._put(BoardWatch(calibration_id=calibration_id, active=False, slot_s=self.slot_s))

    def _keep(self, view: BoardView) -> None:
        with self._lock:
            if self._watch is None or view.calibration_id != self._watch.calibration_id:
                return
            self._looked[view.camera] += 1
            if view.corners:
                cells = board_cells(view.corners, width_px=view.width_px, height_px=view.height_px, grid=GRID)
                self._sightings.append(BoardSighting(view.camera, view.timestamp_ns, cells))

    def coverage(self, calibration_id: str, cameras: list[str]) -> dict | None:
        """:func:`coverage_summary` of the board recording ``calibration_id`` (None when it is not the one
        watched); puts the watch again every ``REWATCH_S`` s while read, for a detector node restarted since."""
        with self._lock:
            watch = self._watch
            if watch is None or watch.calibration_id != calibration_id:
                return None
            sightings, looked = list(self._sightings), dict(self._looked)
            if self._active and time.monotonic() - self._put_s > REWATCH_S:
                self._put(watch)
        return coverage_summary(sightings, looked, cameras=cameras, slot_s=watch.slot_s)

    def close(self) -> None:
        self._sub.undeclare()
        self._pub.undeclare()
