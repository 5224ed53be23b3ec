"""Reprocessing results in the catalog database, keyed by (trial, method, parameters).

One table, ``method_results``, next to the catalog's own tables (same database, its own SQLAlchemy
metadata, created on first use). A row holds the quality metrics (GC_d, losses, ground-truth errors),
the gait summary, the residuals against a reference (walkway or ground truth) per footfall, and where the
trajectory file went. Writes are idempotent: the unique key (trial_id, method, params_key) makes a second
write of the same result a no-op (the first one wins), so a task retried after a crash, or run twice
by two executors, never duplicates or overwrites a result.
"""

from __future__ import annotations

import json
import time
import weakref
from dataclasses import dataclass, field

from gaitcap.services.catalog import Catalog
from sqlalchemy import Float, Integer, String, Text, UniqueConstraint, select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column


class _Base(DeclarativeBase):
    pass


class MethodResultRow(_Base):
    __tablename__ = "method_results"
    __table_args__ = (UniqueConstraint("trial_id", "method", "params_key"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    trial_id: Mapped[str] = mapped_column(String(64), index=True)
    method: Mapped[str] = mapped_column(String(32))
    params_key: Mapped[str] = mapped_column(String(32), index=True)
    spec_json: Mapped[str] = mapped_column(Text)
    config_json: Mapped[str] = mapped_column(Text)
    status: Mapped[str] = mapped_column(String(16))  # ok | failed
    error: Mapped[str] = mapped_column(Text, default="")
    created_at: Mapped[float] = mapped_column(Float)
    elapsed_s: Mapped[float] = mapped_column(Float, default=0.0)
    worker: Mapped[str] = mapped_column(String(128), default="")
    skeleton: Mapped[str] = mapped_column(String(32), default="")
    metrics_json: Mapped[str] = mapped_column(Text, default="{}")
    gait_json: Mapped[str] = mapped_column(Text, default="{}")
    residuals_json: Mapped[str] = mapped_column(Text, default="{}")
    artifacts_json: Mapped[str] = mapped_column(Text, default="{}")


@dataclass(frozen=True)
class MethodResult:
    """One stored result. ``metrics``: GC_5/10/20, L_reproj, L_skeleton, L_smooth (+ MPJPE, heel/toe
    errors with ground truth); ``gait``: summary (name -> {mean, sd, unit}) and step count;
    ``residuals``: parameter -> per-footfall kinematic minus reference (mm), with ``reference``."""

    trial_id: str
    method: str
    params_key: str
    spec: dict
    status: str
    error: str = ""
    created_at: float = 0.0
    elapsed_s: float = 0.0
    worker: str = ""
    skeleton: str = ""
    metrics: dict = field(default_factory=dict)
    gait: dict = field(default_factory=dict)
    residuals: dict = field(default_factory=dict)
    artifacts: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def comparable(self) -> dict:
        """Everything that the computation determines (not when, where or how long): equal for equal
        inputs whichever executor ran it."""
        return {"trial_id": self.trial_id, "method": self.method, "params_key": self.params_key,
                "status": self.status, "error": self.error, "skeleton": self.skeleton, "metrics": self.metrics,
                "gait": self.gait, "residuals": self.residuals}


_READY: weakref.WeakSet = weakref.WeakSet()  # engines whose table exists


def ensure_table(catalog: Catalog) -> None:
    """Create the table on first use (once per engine)."""
    if catalog.engine not in _READY:
        _Base.metadata.create_all(catalog.engine)
        _READY.add(catalog.engine)


def _dumps(value) -> str:
    return json.dumps(value, sort_keys=True, default=float, allow_nan=True)


def put_result(catalog: Catalog, result: MethodResult, *, config: dict) -> bool:
    """Insert ``result`` unless (trial, method, params_key) is already stored; True if inserted."""
    ensure_table(catalog)
    row = MethodResultRow(
        trial_id=result.trial_id, method=result.method, params_key=result.params_key,
        spec_json=_dumps(result.spec), config_json=_dumps(config), status=result.status,
        error=result.error[:4000], created_at=result.created_at or time.time(), elapsed_s=float(result.elapsed_s),
        worker=result.worker, skeleton=result.skeleton, metrics_json=_dumps(result.metrics),
        gait_json=_dumps(result.gait), residuals_json=_dumps(result.residuals),
        artifacts_json=_dumps(result.artifacts))
    try:
        with catalog.session() as s:
            exists = s.scalars(select(MethodResultRow.id).where(*_key_filter(result.trial_id, result.method,
                                                                             result.params_key))).first()
            if exists is not None:
                return False
            s.add(row)
        return True
    except IntegrityError:  # a concurrent writer inserted the same key first
        return False


def _key_filter(trial_id: str, method: str, params_key: str):
    return (MethodResultRow.trial_id == trial_id, MethodResultRow.method == method,
            MethodResultRow.params_key == params_key)


def _info(row: MethodResultRow) -> MethodResult:
    return MethodResult(row.trial_id, row.method, row.params_key, json.loads(row.spec_json), row.status,
                        row.error, row.created_at, row.elapsed_s, row.worker, row.skeleton,
                        json.loads(row.metrics_json), json.loads(row.gait_json), json.loads(row.residuals_json),
                        json.loads(row.artifacts_json))


def get_result(catalog: Catalog, trial_id: str, method: str, params_key: str) -> MethodResult | None:
    ensure_table(catalog)
    with catalog.session() as s:
        row = s.scalars(select(MethodResultRow).where(*_key_filter(trial_id, method, params_key))).first()
        return None if row is None else _info(row)


def done_keys(catalog: Catalog) -> set[tuple[str, str, str]]:
    """(trial_id, method, params_key) of every stored result."""
    ensure_table(catalog)
    with catalog.session() as s:
        rows = s.execute(select(MethodResultRow.trial_id, MethodResultRow.method, MethodResultRow.params_key))
        return {tuple(r) for r in rows}


def list_results(catalog: Catalog, *, trial_ids=None, params_keys=None) -> list[MethodResult]:
    """Stored results (optionally only those trials / parameter keys), oldest first."""
    ensure_table(catalog)
    q = select(MethodResultRow).order_by(MethodResultRow.id)
    if trial_ids is not None:
        q = q.where(MethodResultRow.trial_id.in_(list(trial_ids)))
    if params_keys is not None:
        q = q.where(MethodResultRow.params_key.in_(list(params_keys)))
    with catalog.session() as s:
        return [_info(r) for r in s.scalars(q)]


def delete_failed(catalog: Catalog, trial_ids=None) -> int:
    """Forget failed results (so ``--retry-failed`` computes them again); returns how many."""
    ensure_table(catalog)
    with catalog.session() as s:
        q = select(MethodResultRow).where(MethodResultRow.status == "failed")
        if trial_ids is not None:
            q = q.where(MethodResultRow.trial_id.in_(list(trial_ids)))
        rows = list(s.scalars(q))
        for r in rows:
            s.delete(r)
        return len(rows)
