"""A Stop pressed while the catalog is unreachable: the room's recorder is stopped at once (it never needs the
catalog, so the recording is finished and safe on disk), and the Stop's catalog writes (``recording ->
stopping -> recorded``, the recorder's summary and checksum, processing queued, the audit row) wait in
:class:`PendingStops` and are tried again every ``period_s`` until the catalog answers (a thread of the
room's API process). Nothing is lost if the API process dies meanwhile either: the trial is still
``recording`` in the catalog, its finished file on disk, and the trial guard recovers and queues it.
"""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass
from pathlib import Path

from gaitcap.services import catalog as cat
from gaitcap.services.live.rig_check import recorder_warnings
from gaitcap.services.processing.store import recording_checksum
from sqlalchemy.exc import OperationalError

log = logging.getLogger(__name__)
RESUMED_DETAIL = "written once the catalog was back"  # the audit row of a Stop written late


def checksum_of(trial: cat.TrialInfo) -> dict:
    """The finished recording's SHA-256 and size, which a worker on any host checks its copy against ({}
    when the file is not on this host: the worker then takes what it finds unchecked)."""
    try:
        return recording_checksum(Path(trial.recording_path))
    except OSError as exc:
        log.warning("trial %s: no checksum of its recording (%s)", trial.id, exc)
        return {}


def finish_stop(db: cat.Catalog, trial: cat.TrialInfo, summary: dict, *, stopped_at: float) -> cat.TrialInfo:
    """A stopped trial's catalog writes once its recorder has finished the file: the recorder's summary,
    warnings and checksum, then ``stopping -> recorded`` with processing queued."""
    cat.set_quality(db, trial.id, "recorder", {**summary, "warnings": recorder_warnings(summary),
                                               **checksum_of(trial)})
    return cat.set_state(db, trial.id, "recorded", expect="stopping", enqueue=True, stopped_at=stopped_at,
                         stage="waiting for a worker", progress=0.0)


@dataclass(frozen=True)
class PendingStop:
    trial_id: str
    summary: dict
    actor: str
    stopped_at: float  # UNIX s, when the recorder stopped


class PendingStops:
    """``PendingStops(catalog).start()``; :meth:`add` a Stop whose recorder has stopped; :meth:`close`."""

    def __init__(self, catalog: cat.Catalog, *, period_s: float = 1.0) -> None:
        self.catalog, self.period_s = catalog, period_s
        self._lock = threading.Lock()
        self._pending: dict[str, PendingStop] = {}
        self._stop, self._wake = threading.Event(), threading.Event()
        self._thread = threading.Thread(target=self._run, name="pending-stops", daemon=True)

    def start(self) -> PendingStops:
        self._thread.start()
        return self

    def add(self, stop: PendingStop) -> None:
        with self._lock:
            self._pending[stop.trial_id] = stop
        log.warning("trial %s: stopped and saved; the catalog is unreachable, its Stop is written once it is back "
                    "(tried every %g s)", stop.trial_id, self.period_s)

    def ids(self) -> set[str]:
        """The trials whose Stop waits for the catalog (the trial guard leaves them alone)."""
        with self._lock:
            return set(self._pending)

    def write(self, stop: PendingStop) -> None:
        """The Stop's catalog writes (raises while the catalog is unreachable). Each step is taken only if
        not yet taken, so a write cut off half-way (the catalog gone again, a server error) is finished by
        the next try: the audit row once, ``recording -> stopping``, then the recorder's summary and
        ``stopping -> recorded``."""
        rows = cat.audit_entries(self.catalog, trial_id=stop.trial_id)
        if not any(r.action == "stop" and r.detail == RESUMED_DETAIL for r in rows):
            cat.audit(self.catalog, actor=stop.actor, action="stop", trial_id=stop.trial_id, detail=RESUMED_DETAIL)
        trial = cat.get_trial(self.catalog, stop.trial_id)
        if trial.state == "recording":
            trial = cat.set_state(self.catalog, stop.trial_id, "stopping", expect="recording",
                                  stage="saving the recording")
        elif trial.state != "stopping":  # moved on meanwhile (another Stop, the guard): nothing to write
            log.warning("trial %s: its pending Stop is not written: the trial is %s", stop.trial_id, trial.state)
            return
        finish_stop(self.catalog, trial, stop.summary, stopped_at=stop.stopped_at)
        log.info("trial %s: its Stop is written (the catalog is back); processing queued", stop.trial_id)

    def flush(self) -> int:
        """Write every pending Stop that the catalog takes now; how many are still pending."""
        for stop in sorted(self.ids()):
            with self._lock:
                pending = self._pending.get(stop)
            try:
                self.write(pending)
            except OperationalError as exc:  # still unreachable: kept, tried again next period
                log.debug("trial %s: Stop still pending (%s)", stop, type(exc).__name__)
                continue
            except Exception:  # anything else is named, and still kept: the recording is safe on disk
                log.warning("trial %s: its Stop could not be written; tried again in %g s", stop, self.period_s,
                            exc_info=True)
                continue
            with self._lock:
                self._pending.pop(stop, None)
        return len(self.ids())

    def _run(self) -> None:
        while not self._stop.wait(self.period_s):
            if self.ids():
                self.flush()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(5)
        if self.ids():
            log.error("trials %s: their Stop was not written before the API stopped; the trial guard recovers "
                      "them when it runs again", sorted(self.ids()))
