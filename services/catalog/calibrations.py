"""Camera calibrations, one record type for all: uploaded ones and board recordings.

An upload is stored ``done`` at once. A board recording is ``recording`` -> ``calibrating`` (Stop queues a
``calibrate`` job in the same transaction; a worker computes it under a lease) -> ``done`` or ``failed``
(the reason in ``error``; never activated). The newest ``done`` calibration (by ``done_at``) is the
active one: later trials use it.
"""

from __future__ import annotations

import json
import secrets
import time
from dataclasses import dataclass

from gaitcap.reconstruction.jsonable import json_ready
from gaitcap.services.catalog.db import Catalog
from gaitcap.services.catalog.jobs import new_job
from gaitcap.services.catalog.models import Calibration, Trial
from gaitcap.services.catalog.rooms import DEFAULT_ROOM, check_room, slot_of
from sqlalchemy import select
from sqlalchemy.exc import IntegrityError

RECORDING, CALIBRATING, DONE, FAILED = "recording", "calibrating", "done", "failed"
UPLOADED, BOARD_RECORDING = "uploaded", "board recording"


class CalibrationBusy(RuntimeError):
    """Something (a trial or another board recording) is recording; only one at a time."""


class CalibrationNotFound(KeyError):
    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "calibration not found"


@dataclass(frozen=True)
class CalibrationInfo:
    """A detached snapshot of a calibration (times UNIX s); ``report``: the quality report (dict);
    ``frames``: images in the board recording (None: unknown or uploaded); ``board``: the board filmed,
    the fields of a board file's ``[board]`` table (None: not given, the default board)."""

    id: str
    kind: str
    state: str
    created_at: float
    done_at: float | None
    source: str
    started_at: float | None
    stopped_at: float | None
    started_by: str
    recording_path: str
    frames: int | None
    stage: str
    progress: float
    error: str
    report: dict
    has_toml: bool
    board: dict | None = None
    room: str = DEFAULT_ROOM


def _info(row: Calibration) -> CalibrationInfo:
    return CalibrationInfo(
        id=row.id, kind=row.kind, state=row.state, created_at=row.created_at, done_at=row.done_at,
        source=row.source, started_at=row.started_at, stopped_at=row.stopped_at, started_by=row.started_by,
        recording_path=row.recording_path, frames=row.frames, stage=row.stage, progress=row.progress,
        error=row.error, report=json.loads(row.report_json or "{}"), has_toml=bool(row.toml),
        board=json.loads(row.board) if row.board else None, room=row.room or DEFAULT_ROOM,
    )


def new_calibration_id() -> str:
    return f"C{time.strftime('%Y%m%d-%H%M%S', time.gmtime())}-{secrets.token_hex(3)}"


def add_calibration(catalog: Catalog, *, toml: str, source: str = "", report: dict | None = None,
                    cal_id: str | None = None, room: str = DEFAULT_ROOM) -> str:
    """Store an uploaded calibration of ``room``'s rig, active there at once; returns its id (``C<date>-<hex>``,
    or ``cal_id``)."""
    check_room(room)
    if not toml.strip():
        raise ValueError("toml: calibration text is empty")
    cal_id, now = cal_id or new_calibration_id(), time.time()
    with catalog.session() as s:
        s.add(Calibration(id=cal_id, kind=UPLOADED, state=DONE, created_at=now, done_at=now, source=source,
                          toml=toml, report_json=json.dumps(json_ready(report or {}), default=float), room=room))
    return cal_id


def latest_calibration(catalog: Catalog, room: str = DEFAULT_ROOM) -> tuple[str, str] | None:
    """(id, toml) of ``room``'s active calibration (its newest ``done`` one), or None."""
    with catalog.reading() as s:
        q = (select(Calibration).where(Calibration.state == DONE, Calibration.room == check_room(room))
             .order_by(Calibration.done_at.desc()))
        row = s.scalars(q).first()
        return None if row is None else (row.id, row.toml)


def get_calibration(catalog: Catalog, cal_id: str) -> CalibrationInfo:
    with catalog.reading() as s:
        return _info(_row(s, cal_id, expect=None))


def calibration_toml(catalog: Catalog, cal_id: str) -> str:
    """The TOML text ('' while it is not computed yet); CalibrationNotFound for an unknown id."""
    with catalog.reading() as s:
        return _row(s, cal_id, expect=None).toml


def list_calibrations(catalog: Catalog, *, limit: int = 50, room: str | None = None) -> list[CalibrationInfo]:
    """Every calibration (uploads and board recordings), newest first; ``room``: that room's only."""
    with catalog.reading() as s:
        q = select(Calibration).order_by(Calibration.created_at.desc()).limit(limit)
        if room is not None:
            q = q.where(Calibration.room == check_room(room))
        return [_info(r) for r in s.scalars(q)]


def current_board_recording(catalog: Catalog, room: str = DEFAULT_ROOM) -> CalibrationInfo | None:
    """The board recording under way in ``room``, if any."""
    with catalog.reading() as s:
        row = s.scalars(select(Calibration).where(Calibration.recording_slot == slot_of(s, room))).first()
        return None if row is None else _info(row)


def start_board_recording(catalog: Catalog, *, recording_path_for, started_by: str = "",
                          board: dict | None = None, room: str = DEFAULT_ROOM) -> CalibrationInfo:
    """A new board recording in state ``recording``; CalibrationBusy naming what records when a trial
    or another board recording is under way. ``recording_path_for(cal_id) -> str``: where the MCAP goes;
    ``board``: the board filmed (a board file's ``[board]`` fields; None: the default board); ``room``: the
    room whose rig it films (its own slot: other rooms record on)."""
    cal_id, now = new_calibration_id(), time.time()
    try:
        with catalog.session() as s:
            slot = slot_of(s, room)
            trial = s.scalars(select(Trial.id).where(Trial.recording_slot == slot)).first()
            if trial is not None:
                raise CalibrationBusy(f"trial {trial} is recording; stop it before recording the board")
            busy = s.scalars(select(Calibration.id).where(Calibration.recording_slot == slot)).first()
            if busy is not None:
                raise CalibrationBusy(f"board recording {busy} is already under way; stop it first")
            row = Calibration(id=cal_id, kind=BOARD_RECORDING, state=RECORDING, recording_slot=slot, room=room,
                              created_at=now,
                              started_at=now, started_by=started_by, source=f"board recording by {started_by or 'unknown'}",
                              recording_path=str(recording_path_for(cal_id)), stage="recording the board",
                              progress=0.0, error="", toml="", report_json="{}",
                              board=json.dumps(board) if board else "")
            s.add(row)
            s.flush()
            return _info(row)
    except IntegrityError as exc:  # lost a race for the slot
        raise CalibrationBusy("another board recording started at the same time") from exc


def queue_calibration(catalog: Catalog, cal_id: str, *, frames: int | None = None) -> CalibrationInfo:
    """The board recording stopped: ``calibrating``, and a ``calibrate`` job queued in the same
    transaction (a worker takes it). ValueError when it is not ``recording``."""
    with catalog.session() as s:
        row = _row(s, cal_id, expect=RECORDING)
        row.state, row.recording_slot, row.stopped_at = CALIBRATING, None, time.time()
        row.stage, row.progress, row.frames = "waiting to calibrate", 0.0, frames
        s.add(new_job("calibrate", calibration_id=cal_id))
        s.flush()
        return _info(row)


def _row(s, cal_id: str, *, expect: str | None) -> Calibration:
    row = s.get(Calibration, cal_id)
    if row is None:
        raise CalibrationNotFound(f"calibration {cal_id} not found")
    if expect is not None and row.state != expect:
        raise ValueError(f"calibration {cal_id} is {row.state}, not {expect}")
    return row


UPDATABLE = frozenset({"state", "stopped_at", "stage", "progress", "error"})


def update_calibration(catalog: Catalog, cal_id: str, *, expect: str | None = None, **fields) -> CalibrationInfo:
    """Set ``fields`` (one of :data:`UPDATABLE`; ValueError when ``expect`` is not the state). Leaving
    ``recording`` frees the recording slot."""
    unknown = sorted(set(fields) - UPDATABLE)
    if unknown:
        raise ValueError(f"calibration fields {unknown} cannot be set (settable: {sorted(UPDATABLE)})")
    with catalog.session() as s:
        row = _row(s, cal_id, expect=expect)
        for key, value in fields.items():
            setattr(row, key, value)
        if row.state != RECORDING:
            row.recording_slot = None
        s.flush()
        return _info(row)


def finish_calibration(catalog: Catalog, cal_id: str, *, toml: str, report: dict, failed: list[str],
                       problems: str = "") -> CalibrationInfo:
    """Store the computed calibration. No failed camera: ``done`` (the active one from now on);
    otherwise ``failed`` naming the cameras, and never activated."""
    with catalog.session() as s:
        row = _row(s, cal_id, expect=CALIBRATING)
        row.toml, row.report_json = toml, json.dumps(json_ready(report), default=float)
        row.stage, row.progress = "", 1.0
        if failed:
            row.state = FAILED
            row.error = f"cameras {', '.join(failed)} failed the quality checks" + (f": {problems}" if problems else "")
        else:
            row.state, row.done_at = DONE, time.time()
        s.flush()
        return _info(row)


def refuse_calibration(catalog: Catalog, cal_id: str, *, error: str, report: dict) -> CalibrationInfo:
    """The recording gave no calibration: ``failed`` with ``error`` and ``report`` (what was found per
    camera), no TOML, never activated."""
    with catalog.session() as s:
        row = _row(s, cal_id, expect=CALIBRATING)
        row.report_json = json.dumps(json_ready(report), default=float)
        row.state, row.stage, row.progress, row.error = FAILED, "", 1.0, error
        s.flush()
        return _info(row)
