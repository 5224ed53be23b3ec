"""Board recordings and their calibrations: start (one recording of any kind at a time), stop, results.

A run is ``recording`` -> ``calibrating`` -> ``done`` (its calibration stored in ``calibrations`` under
the same id: the active one for later trials) or ``failed`` (the reason in ``error``; never activated).
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass

from gaitcap.reconstruction.jsonable import json_ready
from gaitcap.services.catalog.calibrations import add_calibration, new_calibration_id
from gaitcap.services.catalog.db import Catalog
from gaitcap.services.catalog.models import Calibration, CalibrationRun, Trial
from sqlalchemy import select
from sqlalchemy.exc import IntegrityError

RECORDING, CALIBRATING, DONE, FAILED = "recording", "calibrating", "done", "failed"


class CalibrationBusy(RuntimeError):
    """Something (a trial or another board recording) is recording; only one at a time."""


class CalibrationNotFound(KeyError):
    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "calibration not found"


@dataclass(frozen=True)
class CalibrationRunInfo:
    """A detached snapshot of a run (times UNIX s); ``report``: the quality report (dict)."""

    id: str
    state: str
    created_at: float
    started_at: float | None
    stopped_at: float | None
    started_by: str
    recording_path: str
    stage: str
    progress: float
    error: str
    report: dict
    calibration_id: str | None
    has_toml: bool


def _info(row: CalibrationRun) -> CalibrationRunInfo:
    return CalibrationRunInfo(
        id=row.id, state=row.state, created_at=row.created_at, started_at=row.started_at,
        stopped_at=row.stopped_at, started_by=row.started_by, recording_path=row.recording_path,
        stage=row.stage, progress=row.progress, error=row.error, report=json.loads(row.report_json or "{}"),
        calibration_id=row.calibration_id, has_toml=bool(row.toml),
    )


def current_board_recording(catalog: Catalog) -> CalibrationRunInfo | None:
    with catalog.reading() as s:
        row = s.scalars(select(CalibrationRun).where(CalibrationRun.recording_slot == 1)).first()
        return None if row is None else _info(row)


def start_calibration_run(catalog: Catalog, *, recording_path_for, started_by: str = "") -> CalibrationRunInfo:
    """A new run in state ``recording``; CalibrationBusy naming what records when a trial or another
    board recording is under way. ``recording_path_for(run_id) -> str``: where the MCAP goes."""
    run_id, now = new_calibration_id(), time.time()
    try:
        with catalog.session() as s:
            trial = s.scalars(select(Trial.id).where(Trial.recording_slot == 1)).first()
            if trial is not None:
                raise CalibrationBusy(f"trial {trial} is recording; stop it before recording the board")
            busy = s.scalars(select(CalibrationRun.id).where(CalibrationRun.recording_slot == 1)).first()
            if busy is not None:
                raise CalibrationBusy(f"board recording {busy} is already under way; stop it first")
            row = CalibrationRun(id=run_id, state=RECORDING, recording_slot=1, created_at=now, started_at=now,
                                 started_by=started_by, recording_path=str(recording_path_for(run_id)),
                                 stage="recording the board", progress=0.0, error="", toml="", report_json="{}")
            s.add(row)
            s.flush()
            return _info(row)
    except IntegrityError as exc:  # lost a race for the slot
        raise CalibrationBusy("another board recording started at the same time") from exc


def get_calibration_run(catalog: Catalog, run_id: str) -> CalibrationRunInfo:
    with catalog.reading() as s:
        row = s.get(CalibrationRun, run_id)
        if row is None:
            raise CalibrationNotFound(f"calibration {run_id} not found")
        return _info(row)


def list_calibration_runs(catalog: Catalog, *, limit: int = 50) -> list[CalibrationRunInfo]:
    with catalog.reading() as s:
        q = select(CalibrationRun).order_by(CalibrationRun.created_at.desc()).limit(limit)
        return [_info(r) for r in s.scalars(q)]


def uploaded_calibrations(catalog: Catalog, *, limit: int = 50) -> list[tuple[str, float, str]]:
    """(id, created_at, source) of calibrations that came from no board recording (uploads, the stack)."""
    with catalog.reading() as s:
        runs = select(CalibrationRun.id)
        q = (select(Calibration.id, Calibration.created_at, Calibration.source)
             .where(Calibration.id.not_in(runs)).order_by(Calibration.created_at.desc()).limit(limit))
        return [tuple(r) for r in s.execute(q)]


def update_calibration_run(catalog: Catalog, run_id: str, *, expect: str | None = None, **fields) -> CalibrationRunInfo:
    """Set ``fields`` (ValueError when ``expect`` is not the run's state). Leaving ``recording`` frees
    the recording slot."""
    with catalog.session() as s:
        row = s.get(CalibrationRun, run_id)
        if row is None:
            raise CalibrationNotFound(f"calibration {run_id} not found")
        if expect is not None and row.state != expect:
            raise ValueError(f"calibration {run_id} is {row.state}, not {expect}")
        for key, value in fields.items():
            if not hasattr(CalibrationRun, key):
                raise ValueError(f"calibration run field {key!r} does not exist")
            setattr(row, key, value)
        if row.state != RECORDING:
            row.recording_slot = None
        s.flush()
        return _info(row)


def finish_calibration_run(catalog: Catalog, run_id: str, *, toml: str, report: dict, failed: list[str],
                           problems: str = "") -> CalibrationRunInfo:
    """Store the result. No failed camera: the calibration is stored (same id) and becomes active;
    otherwise the run is ``failed`` naming the cameras, and nothing is activated."""
    report_json = json.dumps(json_ready(report), default=float)
    if failed:
        return update_calibration_run(catalog, run_id, state=FAILED, toml=toml, report_json=report_json,
                                      stage="", progress=1.0,
                                      error=f"cameras {', '.join(failed)} failed the quality checks"
                                            + (f": {problems}" if problems else ""))
    info = get_calibration_run(catalog, run_id)
    add_calibration(catalog, toml=toml, report=report, cal_id=run_id,
                    source=f"board recording by {info.started_by or 'unknown'}")
    return update_calibration_run(catalog, run_id, state=DONE, toml=toml, report_json=report_json, stage="",
                                  progress=1.0, calibration_id=run_id)


def calibration_run_toml(catalog: Catalog, run_id: str) -> str:
    with catalog.reading() as s:
        row = s.get(CalibrationRun, run_id)
        if row is None:
            raise CalibrationNotFound(f"calibration {run_id} not found")
        return row.toml
