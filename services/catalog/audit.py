"""The audit log: who started, stopped, viewed or downloaded which trial."""

from __future__ import annotations

from dataclasses import dataclass

from gaitcap.services.catalog.audit_queue import audit_row, queue_of
from gaitcap.services.catalog.db import Catalog
from gaitcap.services.catalog.models import AuditEntry
from sqlalchemy import select

READ_ACTIONS = frozenset({"view", "download"})  # what a read route records (a GET writes nothing else)
FLUSH_S = 0.5  # s a read of the audit rows waits for rows queued before it


@dataclass(frozen=True)
class AuditInfo:
    at: float
    actor: str
    action: str
    trial_id: str | None
    detail: str


def record(catalog: Catalog, *, actor: str, action: str, trial_id: str | None = None, detail: str = "") -> None:
    """One audit row. The row of a read (``action`` in :data:`READ_ACTIONS`) is handed to the catalog's audit
    queue when one runs in this process (it never waits for the write lock,
    :mod:`~gaitcap.services.catalog.audit_queue`); any other row is written now, in the caller's request."""
    if action in READ_ACTIONS and (q := queue_of(catalog)) is not None:
        q.put(actor=actor, action=action, trial_id=trial_id, detail=detail)
        return
    with catalog.session() as s:
        s.add(audit_row(actor=actor, action=action, trial_id=trial_id, detail=detail))


def entries(catalog: Catalog, *, trial_id: str | None = None, limit: int = 200) -> list[AuditInfo]:
    """Newest first. Rows queued in this process before the call are waited for, at most ``FLUSH_S`` (a read
    never waits longer for a locked catalog: past it, rows still queued are not listed yet)."""
    if (pending := queue_of(catalog)) is not None:
        pending.flush(FLUSH_S)
    with catalog.reading() as s:
        q = select(AuditEntry).order_by(AuditEntry.id.desc()).limit(limit)
        if trial_id is not None:
            q = q.where(AuditEntry.trial_id == trial_id)
        return [AuditInfo(e.at, e.actor, e.action, e.trial_id, e.detail) for e in s.scalars(q)]
