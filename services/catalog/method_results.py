"""The one results store, keyed by (trial, method, parameters).

Two writers, one keyed read. Research reprocessing writes ``method_results`` rows: the quality metrics
(GC_d, losses, ground-truth errors), the gait summary, the residuals against a reference (walkway or
ground truth) per footfall and where its files went. Writes are idempotent: the unique key (trial_id,
method, params_key) makes a second write of the same result a no-op (the first one wins), so a task
retried after a crash, or run twice by two executors, never duplicates or overwrites a result. The
clinic's worker writes each stage of a trial into ``results`` (:mod:`gaitcap.services.catalog.results`; a
reprocessed stage replaces its row) under the method and the parameters key of the config that computed it
(:mod:`gaitcap.services.catalog.method_keys`, the key research computes).

:func:`get_result` and :func:`list_results` read both: a research row where research computed the key (it
carries the residuals and ground-truth errors the clinic does not compute), else the clinic's stage row
under the same key (``stage`` says which; no residuals). :func:`is_done`, :func:`done_keys` and :func:`delete_failed`
concern research's own rows: research computes a key the clinic holds again, with its references.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field

from gaitcap.services.catalog.db import Catalog
from gaitcap.services.catalog.models import MethodResultRow, Result, Step
from gaitcap.services.catalog.results import summary_of_row
from sqlalchemy import func, select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session


@dataclass(frozen=True)
class MethodResult:
    """One stored result. ``metrics``: GC_5/10/20, L_reproj, L_skeleton, L_smooth (+ MPJPE, heel/toe
    errors with ground truth); ``gait``: summary (name -> {mean, sd, unit}), step count and the problem
    when there is no gait analysis; ``residuals``: parameter -> per-footfall kinematic minus reference (mm),
    with ``reference``; ``stage``: the clinic's stage when the clinic's worker computed it ('' for research)."""

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
    stage: str = ""

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def key(self) -> tuple[str, str, str]:
        return self.trial_id, self.method, self.params_key

    def comparable(self) -> dict:
        """Everything that the computation determines (not when, where or how long): equal for equal
        inputs whichever executor ran it."""
        return {"trial_id": self.trial_id, "method": self.method, "params_key": self.params_key,
                "status": self.status, "error": self.error, "skeleton": self.skeleton, "metrics": self.metrics,
                "gait": self.gait, "residuals": self.residuals}


def _dumps(value) -> str:
    return json.dumps(value, sort_keys=True, default=float, allow_nan=True)


def put_result(catalog: Catalog, result: MethodResult, *, config: dict) -> bool:
    """Insert research's ``result`` unless (trial, method, params_key) is already stored; True if inserted."""
    row = MethodResultRow(
        trial_id=result.trial_id, method=result.method, params_key=result.params_key,
        spec_json=_dumps(result.spec), config_json=_dumps(config), status=result.status,
        error=result.error[:4000], created_at=result.created_at or time.time(), elapsed_s=float(result.elapsed_s),
        worker=result.worker, skeleton=result.skeleton, metrics_json=_dumps(result.metrics),
        gait_json=_dumps(result.gait), residuals_json=_dumps(result.residuals),
        artifacts_json=_dumps(result.artifacts))
    try:
        with catalog.session() as s:
            exists = s.scalars(select(MethodResultRow.id).where(*_research_key(*result.key))).first()
            if exists is not None:
                return False
            s.add(row)
        return True
    except IntegrityError:  # a concurrent writer inserted the same key first
        return False


def _research_key(trial_id: str, method: str, params_key: str):
    return (MethodResultRow.trial_id == trial_id, MethodResultRow.method == method,
            MethodResultRow.params_key == params_key)


def _research(row: MethodResultRow) -> MethodResult:
    return MethodResult(row.trial_id, row.method, row.params_key, json.loads(row.spec_json), row.status,
                        row.error, row.created_at, row.elapsed_s, row.worker, row.skeleton,
                        json.loads(row.metrics_json), json.loads(row.gait_json), json.loads(row.residuals_json),
                        json.loads(row.artifacts_json))


def _clinic(s: Session, row: Result) -> MethodResult:
    """A clinic stage row as research reads it: its metrics, gait summary and step count, its files."""
    report = json.loads(row.report_json)
    steps = s.scalar(select(func.count()).select_from(Step).where(Step.result_id == row.id))
    gait = {"problem": report.get("problem", ""), "steps": steps, "summary": summary_of_row(s, row.id)}
    return MethodResult(row.trial_id, row.method_name, row.params_key,
                        {"method": row.method_name, "stage": row.stage, "label": row.method}, "ok",
                        created_at=row.created_at, elapsed_s=row.elapsed_s, metrics=json.loads(row.quality_json),
                        gait=gait, artifacts=json.loads(row.artifacts_json), stage=row.stage)


def get_result(catalog: Catalog, trial_id: str, method: str, params_key: str) -> MethodResult | None:
    """The result of the trial under the method config: research's row, else the clinic's stage row."""
    with catalog.reading() as s:
        row = s.scalars(select(MethodResultRow).where(*_research_key(trial_id, method, params_key))).first()
        if row is not None:
            return _research(row)
        stage = s.scalars(select(Result).where(Result.trial_id == trial_id, Result.method_name == method,
                                               Result.params_key == params_key).order_by(Result.id)).first()
        return None if stage is None else _clinic(s, stage)


def is_done(catalog: Catalog, trial_id: str, method: str, params_key: str) -> bool:
    """Whether research stored the key (ok or failed): one of :func:`done_keys`."""
    with catalog.reading() as s:
        return s.scalars(select(MethodResultRow.id).where(*_research_key(trial_id, method, params_key))).first() is not None


def done_keys(catalog: Catalog) -> set[tuple[str, str, str]]:
    """(trial_id, method, params_key) of every result research stored (ok or failed)."""
    with catalog.reading() as s:
        rows = s.execute(select(MethodResultRow.trial_id, MethodResultRow.method, MethodResultRow.params_key))
        return {tuple(r) for r in rows}


def list_results(catalog: Catalog, *, trial_ids=None, params_keys=None) -> list[MethodResult]:
    """Stored results (optionally only those trials / parameter keys), one per key: research's oldest
    first, then the clinic's stage rows under keys research has not computed, oldest first."""
    research = select(MethodResultRow).order_by(MethodResultRow.id)
    clinic = select(Result).where(Result.params_key != "").order_by(Result.id)
    if trial_ids is not None:
        research = research.where(MethodResultRow.trial_id.in_(list(trial_ids)))
        clinic = clinic.where(Result.trial_id.in_(list(trial_ids)))
    if params_keys is not None:
        research = research.where(MethodResultRow.params_key.in_(list(params_keys)))
        clinic = clinic.where(Result.params_key.in_(list(params_keys)))
    with catalog.reading() as s:
        out = [_research(r) for r in s.scalars(research)]
        held = {r.key for r in out}
        for row in s.scalars(clinic):
            if (row.trial_id, row.method_name, row.params_key) not in held:
                out.append(_clinic(s, row))
                held.add(out[-1].key)
        return out


def delete_failed(catalog: Catalog, trial_ids=None) -> int:
    """Forget research's failed results (so ``--retry-failed`` computes them again); returns how many."""
    with catalog.session() as s:
        q = select(MethodResultRow).where(MethodResultRow.status == "failed")
        if trial_ids is not None:
            q = q.where(MethodResultRow.trial_id.in_(list(trial_ids)))
        rows = list(s.scalars(q))
        for r in rows:
            s.delete(r)
        return len(rows)
