"""A capture room's rig state in the central catalog: which cameras its API sees and how they are, rewritten
every ``period_s`` by a thread of the room's API process, so any room's page (and ``GET /rooms``) can show
every room's rig and how long ago it was seen (:func:`gaitcap.services.catalog.rooms.report_rig`)."""

from __future__ import annotations

import logging
import threading
from dataclasses import asdict

from gaitcap.services import catalog as cat
from gaitcap.services.catalog import rooms

log = logging.getLogger(__name__)


def rig_state(link) -> dict:
    """What the room sees of its rig now: each camera's name, fps, health and status in words."""
    cameras = [{k: v for k, v in asdict(c).items() if k in ("name", "fps", "healthy", "status")}
               for c in link.cameras()]
    return {"cameras": cameras, "healthy": sum(c["healthy"] for c in cameras), "seen": len(cameras)}


class RoomReporter:
    """``RoomReporter(catalog, link, room).start()``; :meth:`close` stops it. A failed write (the catalog
    unreachable) is logged once per outage and tried again next period."""

    def __init__(self, catalog: cat.Catalog, link, room: str, *, period_s: float = 2.0) -> None:
        self.catalog, self.link, self.room, self.period_s = catalog, link, room, period_s
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="room-report", daemon=True)
        self._failing = False

    def start(self) -> RoomReporter:
        self.report()
        self._thread.start()
        return self

    def report(self) -> None:
        try:
            rooms.report_rig(self.catalog, self.room, rig_state(self.link))
            if self._failing:
                log.info("room %r: rig state written again", self.room)
            self._failing = False
        except Exception as exc:  # the catalog unreachable: the room records on, the state waits
            if not self._failing:
                log.warning("room %r: rig state not written (%s: %s); trying every %.0f s", self.room,
                            type(exc).__name__, exc, self.period_s)
            self._failing = True

    def _run(self) -> None:
        while not self._stop.wait(self.period_s):
            self.report()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(5)
