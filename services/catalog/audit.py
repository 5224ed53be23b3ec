"""The audit log: who started, stopped, viewed or downloaded which trial."""

from __future__ import annotations

import time
from dataclasses import dataclass

from gaitcap.services.catalog.db import Catalog
from gaitcap.services.catalog.models import AuditEntry
from sqlalchemy import select


@dataclass(frozen=True)
class AuditInfo:
    at: float
    actor: str
    action: str
    trial_id: str | None
    detail: str


def record(catalog: Catalog, *, actor: str, action: str, trial_id: str | None = None, detail: str = "") -> None:
    with catalog.session() as s:
        s.add(AuditEntry(at=time.time(), actor=actor[:128], action=action[:32], trial_id=trial_id,
                         detail=detail[:2000]))


def entries(catalog: Catalog, *, trial_id: str | None = None, limit: int = 200) -> list[AuditInfo]:
    """Newest first."""
    with catalog.reading() as s:
        q = select(AuditEntry).order_by(AuditEntry.id.desc()).limit(limit)
        if trial_id is not None:
            q = q.where(AuditEntry.trial_id == trial_id)
        return [AuditInfo(e.at, e.actor, e.action, e.trial_id, e.detail) for e in s.scalars(q)]
