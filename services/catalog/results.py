"""Gait results per processing stage (preliminary, refined) with their steps and summaries."""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field

from gaitcap.reconstruction.jsonable import finite_or_none
from gaitcap.services.catalog.db import Catalog
from gaitcap.services.catalog.models import Result, Step, Summary
from sqlalchemy import delete, select
from sqlalchemy.orm import Session

STAGES = ("preliminary", "refined")


@dataclass(frozen=True)
class ResultInfo:
    trial_id: str
    stage: str
    method: str
    created_at: float
    elapsed_s: float
    report: dict
    quality: dict
    artifacts: dict
    steps: list[dict] = field(default_factory=list)
    summary: dict[str, dict] = field(default_factory=dict)


def _summary_rows(summary: dict) -> list[Summary]:
    rows = []
    for name, item in summary.items():
        if isinstance(item, dict):
            rows.append(Summary(name=name, value=finite_or_none(item.get("mean", item.get("value"))),
                                sd=finite_or_none(item.get("sd")), unit=str(item.get("unit", ""))))
        else:
            rows.append(Summary(name=name, value=finite_or_none(item), sd=None, unit=""))
    return rows


def store_result(
    catalog: Catalog, *, trial_id: str, stage: str, method: str, steps: list[dict], summary: dict,
    report: dict | None = None, quality: dict | None = None, artifacts: dict | None = None,
    elapsed_s: float = 0.0, method_name: str = "", params_key: str = "",
) -> None:
    """Store (or replace) the result of one stage. ``method``: the method in words; ``method_name`` and
    ``params_key``: the key it is read under with research's results
    (:mod:`gaitcap.services.catalog.method_results`; '' when no method config computed it). ``steps``: dicts
    with ``side``, ``time_s`` and the step's parameters (units in the keys); ``summary``: name -> number or
    {mean, sd, unit}."""
    if stage not in STAGES:
        raise ValueError(f"stage: must be one of {STAGES}, got {stage!r}")
    with catalog.session() as s:
        old = s.scalars(select(Result).where(Result.trial_id == trial_id, Result.stage == stage)).first()
        if old is not None:
            s.execute(delete(Step).where(Step.result_id == old.id))
            s.execute(delete(Summary).where(Summary.result_id == old.id))
            s.delete(old)
            s.flush()
        res = Result(trial_id=trial_id, stage=stage, method=method, method_name=method_name, params_key=params_key,
                     created_at=time.time(),
                     elapsed_s=float(elapsed_s), report_json=json.dumps(report or {}, default=float),
                     quality_json=json.dumps(quality or {}, default=float),
                     artifacts_json=json.dumps(artifacts or {}))
        s.add(res)
        s.flush()
        for i, step in enumerate(steps):
            s.add(Step(result_id=res.id, index=i, side=str(step.get("side", "")),
                       time_s=finite_or_none(step.get("time_s")) or 0.0, values_json=json.dumps(step, default=float)))
        for row in _summary_rows(summary):
            row.result_id = res.id
            s.add(row)


def add_artifacts(catalog: Catalog, trial_id: str, stage: str, artifacts: dict[str, str]) -> None:
    """List files of a stored result (artifact key -> path) once they are written whole: a file is listed
    only after it is in place, so a crash while writing never leaves the catalog naming a missing or half
    file. Raises LookupError when the stage has no result."""
    with catalog.session() as s:
        res = s.scalars(select(Result).where(Result.trial_id == trial_id, Result.stage == stage)).first()
        if res is None:
            raise LookupError(f"trial {trial_id}: no {stage} result to list files on")
        res.artifacts_json = json.dumps({**json.loads(res.artifacts_json), **artifacts})


def get_result(catalog: Catalog, trial_id: str, stage: str | None = None) -> ResultInfo | None:
    """The given stage, or the best available (refined, else preliminary). None if none yet."""
    stages = [stage] if stage else ["refined", "preliminary"]
    with catalog.reading() as s:
        for st in stages:
            res = s.scalars(select(Result).where(Result.trial_id == trial_id, Result.stage == st)).first()
            if res is None:
                continue
            steps = [json.loads(r.values_json) for r in
                     s.scalars(select(Step).where(Step.result_id == res.id).order_by(Step.index))]
            return ResultInfo(res.trial_id, res.stage, res.method, res.created_at, res.elapsed_s,
                              json.loads(res.report_json), json.loads(res.quality_json),
                              json.loads(res.artifacts_json), steps, summary_of_row(s, res.id))
    return None


def summary_of_row(s: Session, result_id: int) -> dict[str, dict]:
    """A stored result's summary: name -> {mean, sd, unit}, in the order stored."""
    return {r.name: {"mean": r.value, "sd": r.sd, "unit": r.unit} for r in
            s.scalars(select(Summary).where(Summary.result_id == result_id).order_by(Summary.id))}


def best_means_of(catalog: Catalog, trial_ids: list[str]) -> dict[str, dict[str, float | None]]:
    """trial id -> summary name -> mean of its best result (refined, else preliminary), as
    :func:`get_result` chooses; one query for many trials. Trials without results are left out."""
    out: dict[str, tuple[str, dict[str, float | None]]] = {}
    q = (select(Result.trial_id, Result.stage, Summary.name, Summary.value)
         .outerjoin(Summary, Summary.result_id == Result.id).where(Result.trial_id.in_(trial_ids)).order_by(Summary.id))
    with catalog.reading() as s:
        for tid, stage, name, value in s.execute(q):
            best = out.get(tid)
            if best is None or (best[0] == "preliminary" and stage == "refined"):
                out[tid] = best = (stage, {})
            if best[0] == stage and name is not None:  # a result without summary rows is still the best
                best[1][name] = value
    return {tid: means for tid, (_, means) in out.items()}


def stages_available(catalog: Catalog, trial_id: str) -> list[str]:
    return stages_of(catalog, [trial_id]).get(trial_id, [])


def stages_of(catalog: Catalog, trial_ids: list[str]) -> dict[str, list[str]]:
    """trial id -> result stages stored (one query for many trials)."""
    out: dict[str, list[str]] = {}
    with catalog.reading() as s:
        for tid, stage in s.execute(select(Result.trial_id, Result.stage).where(Result.trial_id.in_(trial_ids))):
            out.setdefault(tid, []).append(stage)
    return out


def clear_results(catalog: Catalog, trial_id: str) -> int:
    """Remove a trial's results (all stages), e.g. when the patient was chosen anew and the old numbers
    are for someone else; returns how many were removed. The files are replaced by the next processing."""
    with catalog.session() as s:
        ids = list(s.scalars(select(Result.id).where(Result.trial_id == trial_id)))
        if ids:
            s.execute(delete(Step).where(Step.result_id.in_(ids)))
            s.execute(delete(Summary).where(Summary.result_id.in_(ids)))
            s.execute(delete(Result).where(Result.id.in_(ids)))
        return len(ids)
