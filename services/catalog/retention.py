"""Retention: removing one trial from the catalog (its results, steps, jobs, quality: every row that
refers to it through a foreign key, found from the schema), while the audit log keeps its entries."""

from __future__ import annotations

from gaitcap.services.catalog.db import Catalog
from gaitcap.services.catalog.models import Base, Trial
from sqlalchemy import delete, select


def _delete_where(s, table, condition) -> int:
    """Delete the rows of ``table`` matching ``condition`` and, first, every row referring to them."""
    for child in Base.metadata.sorted_tables:
        for fk in child.foreign_keys:
            if fk.column.table is table and child is not table:
                _delete_where(s, child, fk.parent.in_(select(fk.column).where(condition)))
    return s.execute(delete(table).where(condition)).rowcount


def delete_trial_rows(catalog: Catalog, trial_id: str) -> int:
    """Remove the trial and everything that refers to it; returns the number of trial rows removed (0/1)."""
    trials = Trial.__table__
    with catalog.session() as s:
        return _delete_where(s, trials, trials.c.id == trial_id)
