"""Audit rows written by a thread of their own, so a request never waits for the catalog's write lock.

Every route of the API that reads a trial also records who read it (an audit row). Written inline, that
row is a write transaction: with another process (a worker, stopped or slow) holding SQLite's write lock,
the read would wait up to the busy timeout (30 s). With an :class:`AuditQueue` started on a catalog
(the API does at start-up), :func:`gaitcap.services.catalog.audit.record` hands the row to the queue and
returns at once; the queue's thread writes the rows in order, in short transactions of up to
``BATCH`` rows, retrying a failed write (the rows are kept) until it succeeds or the queue is closed.
The row's time is when it was recorded, not when it was written. Reading the audit rows through
:func:`~gaitcap.services.catalog.audit.entries` in the same process waits (at most ``flush_s``) for the
rows queued before it.

At most ``max_pending`` rows wait (100 000, a few MB); beyond that a row is dropped and logged as an
error (the file audit trail, ``api/audit_chain.py``, still has every access).
"""

from __future__ import annotations

import logging
import queue
import threading
import time

from gaitcap.services.catalog.db import Catalog
from gaitcap.services.catalog.models import AuditEntry

log = logging.getLogger(__name__)
BATCH = 200  # rows per write transaction
_CLOSE = object()
_QUEUES: dict[Catalog, AuditQueue] = {}  # the queue started on each open catalog of this process
_REGISTRY_LOCK = threading.Lock()


def audit_row(*, actor: str, action: str, trial_id: str | None, detail: str, at: float | None = None) -> AuditEntry:
    """One audit row with its fields cut to the columns' sizes; ``at``: unix s (default now)."""
    return AuditEntry(at=time.time() if at is None else at, actor=actor[:128], action=action[:32], trial_id=trial_id,
                      detail=detail[:2000])


class AuditQueue:
    """The catalog's audit rows, written by a daemon thread (module docstring)."""

    def __init__(self, catalog: Catalog, *, max_pending: int = 100_000, retry_s: float = 0.5) -> None:
        self.catalog, self.retry_s = catalog, retry_s
        self.dropped = 0
        self._q: queue.Queue = queue.Queue(max_pending)
        self._closing = threading.Event()
        self._thread = threading.Thread(target=self._run, name="catalog-audit", daemon=True)

    def start(self) -> AuditQueue:
        with _REGISTRY_LOCK:
            _QUEUES[self.catalog] = self
        self._thread.start()
        return self

    def put(self, *, actor: str, action: str, trial_id: str | None = None, detail: str = "") -> None:
        """Queue one row (never blocks)."""
        try:
            self._q.put_nowait(dict(actor=actor, action=action, trial_id=trial_id, detail=detail, at=time.time()))
        except queue.Full:
            self.dropped += 1
            log.error("audit queue full (%d rows waiting for the catalog's write lock): row %s %s %s dropped",
                      self._q.maxsize, actor, action, trial_id)

    @property
    def pending(self) -> int:
        """Rows queued and not yet written."""
        return self._q.unfinished_tasks

    def flush(self, timeout_s: float = 5.0) -> bool:
        """Wait until every row queued so far is written; False when ``timeout_s`` passed first."""
        deadline = time.monotonic() + timeout_s
        with self._q.all_tasks_done:
            while self._q.unfinished_tasks:
                left = deadline - time.monotonic()
                if left <= 0 or not self._thread.is_alive():
                    return False
                self._q.all_tasks_done.wait(min(left, 0.1))
        return True

    def close(self, timeout_s: float = 10.0) -> None:
        """Write what is queued (for at most ``timeout_s``), then stop the thread."""
        with _REGISTRY_LOCK:
            if _QUEUES.get(self.catalog) is self:
                del _QUEUES[self.catalog]
        self._q.put(_CLOSE)
        self._thread.join(timeout_s)
        self._closing.set()
        if self._thread.is_alive() or self._q.unfinished_tasks > 1:
            log.error("audit queue closed with %d rows not written (the catalog stayed locked)",
                      self._q.unfinished_tasks - 1)

    def _run(self) -> None:
        while True:
            first = self._q.get()
            rows = [first]
            while len(rows) < BATCH:
                try:
                    rows.append(self._q.get_nowait())
                except queue.Empty:
                    break
            closing = any(r is _CLOSE for r in rows)
            rows = [r for r in rows if r is not _CLOSE]
            self._write(rows)
            for _ in range(len(rows) + closing):
                self._q.task_done()
            if closing:
                return

    def _write(self, rows: list[dict]) -> None:
        while rows:
            try:
                with self.catalog.session() as s:
                    s.add_all([audit_row(**r) for r in rows])
                return
            except Exception:  # locked past the busy timeout, or the database away: keep the rows, try again
                log.exception("writing %d audit rows failed; retrying", len(rows))
                if self._closing.wait(self.retry_s):
                    return


def queue_of(catalog: Catalog) -> AuditQueue | None:
    """The audit queue started on ``catalog`` in this process, if any."""
    return _QUEUES.get(catalog)
