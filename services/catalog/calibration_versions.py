"""Calibration versions: a calibration made from another one (refined from the people in trials) is a new
calibration record, kept with every other, plus a ``calibration_versions`` row naming the one it replaces,
the trials that made it and how far each camera moved. Trials record the calibration they used
(``trials.calibration_id``); applying a version queues the trials that used the one it replaces for
processing again under it (the worker's one processing path), each now naming the new version.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass

from gaitcap.reconstruction.jsonable import json_ready
from gaitcap.services.catalog.calibrations import DONE, CalibrationNotFound, new_calibration_id
from gaitcap.services.catalog.db import Catalog
from gaitcap.services.catalog.models import Calibration, CalibrationVersion, Trial
from gaitcap.services.catalog.states import FINISHED
from gaitcap.services.catalog.trials import set_state
from sqlalchemy import select

REFINED = "refined from people"  # the calibration record's kind


@dataclass(frozen=True)
class VersionInfo:
    """A calibration version (times UNIX s): ``comparison``: per camera, how far it lies from the one it
    replaces ({camera: {centre_mm, rotation_deg, focal_pct}}); ``applied_at``: when its affected trials
    were queued again under it (None: not yet)."""

    calibration_id: str
    replaces_id: str | None
    made_by: str
    trials: tuple[str, ...]
    comparison: dict
    created_at: float
    applied_at: float | None


def _info(row: CalibrationVersion) -> VersionInfo:
    return VersionInfo(row.calibration_id, row.replaces_id, row.made_by, tuple(json.loads(row.trials_json)),
                       json.loads(row.comparison_json), row.created_at, row.applied_at)


def add_version(catalog: Catalog, *, toml: str, replaces_id: str, made_by: str, trials: list[str],
                comparison: dict, report: dict | None = None) -> str:
    """Store a calibration made from ``replaces_id`` (a ``done`` calibration; CalibrationNotFound or
    ValueError naming it otherwise), active at once (the newest ``done``); returns its id."""
    if not toml.strip():
        raise ValueError("toml: calibration text is empty")
    cal_id, now = new_calibration_id(), time.time()
    with catalog.session() as s:
        old = s.get(Calibration, replaces_id)
        if old is None:
            raise CalibrationNotFound(f"calibration {replaces_id} not found (the one the new version replaces)")
        if old.state != DONE:
            raise ValueError(f"calibration {replaces_id} is {old.state}: only a done calibration can be replaced")
        s.add(Calibration(id=cal_id, kind=REFINED, state=DONE, created_at=now, done_at=now,
                          source=f"{made_by} from {replaces_id}", toml=toml, room=old.room,
                          report_json=json.dumps(json_ready(report or {}), default=float)))
        s.flush()
        s.add(CalibrationVersion(calibration_id=cal_id, replaces_id=replaces_id, made_by=made_by,
                                 trials_json=json.dumps(list(trials)),
                                 comparison_json=json.dumps(json_ready(comparison), default=float), created_at=now))
    return cal_id


def get_version(catalog: Catalog, cal_id: str) -> VersionInfo | None:
    """The version record of ``cal_id`` (None: it replaced nothing, e.g. a board calibration)."""
    with catalog.reading() as s:
        row = s.get(CalibrationVersion, cal_id)
        return None if row is None else _info(row)


def lineage(catalog: Catalog, cal_id: str) -> list[str]:
    """``cal_id`` and every calibration it replaced, newest first (the first board calibration last)."""
    chain, seen = [cal_id], {cal_id}
    while (version := get_version(catalog, chain[-1])) is not None and version.replaces_id not in seen:
        chain.append(version.replaces_id)
        seen.add(version.replaces_id)
    return chain


def trials_using(catalog: Catalog, cal_id: str) -> list[str]:
    """The trials that used calibration ``cal_id`` (oldest first)."""
    with catalog.reading() as s:
        q = select(Trial.id).where(Trial.calibration_id == cal_id).order_by(Trial.created_at)
        return list(s.scalars(q))


def trial_version_toml(catalog: Catalog, trial_id: str) -> str | None:
    """The TOML of the calibration version a trial was assigned (None: its calibration is no version, so the
    one its recording carries stands)."""
    with catalog.reading() as s:
        trial = s.get(Trial, trial_id)
        if trial is None or trial.calibration_id is None or s.get(CalibrationVersion, trial.calibration_id) is None:
            return None
        return s.get(Calibration, trial.calibration_id).toml


def apply_version(catalog: Catalog, cal_id: str) -> tuple[list[str], list[str]]:
    """Queue every finished trial that used the calibration ``cal_id`` replaces for processing again under
    ``cal_id`` (each trial's calibration set to it and a processing job queued, in one transaction per
    trial). Returns (queued, skipped: still recording or processing, named with their state); ValueError
    when ``cal_id`` is no version."""
    version = get_version(catalog, cal_id)
    if version is None:
        raise ValueError(f"calibration {cal_id} replaces no other calibration: no trials to reprocess under it")
    queued, skipped = [], []
    for trial_id in trials_using(catalog, version.replaces_id):
        with catalog.reading() as s:
            state = s.get(Trial, trial_id).state
        if state not in FINISHED:
            skipped.append(f"{trial_id} ({state})")
            continue
        set_state(catalog, trial_id, "recorded", expect=state, enqueue=True, calibration_id=cal_id, stage="queued",
                  progress=0.0, error="")
        queued.append(trial_id)
    with catalog.session() as s:
        s.get(CalibrationVersion, cal_id).applied_at = time.time()
    return queued, skipped
