"""Subjects, sessions and trials: creation, the state machine, listing."""

from __future__ import annotations

import time
from dataclasses import dataclass

from gaitcap.services.catalog.db import Catalog
from gaitcap.services.catalog.ids import new_trial_id, validate_id
from gaitcap.services.catalog.jobs import new_job
from gaitcap.services.catalog.models import SessionRow, Subject, Trial
from gaitcap.services.catalog.rooms import DEFAULT_ROOM, check_room, slot_of
from gaitcap.services.catalog.states import HOLDS_SLOT, IllegalTransition, TrialState, sources_of
from sqlalchemy import select, update
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session


class TrialNotFound(KeyError):
    """No trial with that id."""

    def __str__(self) -> str:  # KeyError quotes its message; keep it readable
        return str(self.args[0]) if self.args else "trial not found"


class RecordingBusy(RuntimeError):
    """Another trial is recording in the room; only one may record at a time there."""

    def __init__(self, trial_id: str | None, room: str = DEFAULT_ROOM) -> None:
        where = f" in room {room}" if room else ""
        super().__init__(f"trial {trial_id} is already recording{where}; stop it first")
        self.trial_id = trial_id


@dataclass(frozen=True)
class TrialInfo:
    """A detached snapshot of a trial row (times are UNIX s)."""

    id: str
    subject_id: str
    session: str
    state: str
    created_at: float
    updated_at: float
    started_at: float | None
    stopped_at: float | None
    recording_path: str
    calibration_id: str | None
    stage: str
    progress: float
    error: str
    room: str = DEFAULT_ROOM

    @property
    def duration_s(self) -> float | None:
        if self.started_at is None:
            return None
        return (self.stopped_at or time.time()) - self.started_at


def _info(trial: Trial, session_label: str) -> TrialInfo:
    return TrialInfo(
        id=trial.id, subject_id=trial.subject_id, session=session_label, state=trial.state,
        created_at=trial.created_at, updated_at=trial.updated_at, started_at=trial.started_at,
        stopped_at=trial.stopped_at, recording_path=trial.recording_path,
        calibration_id=trial.calibration_id, stage=trial.stage, progress=trial.progress, error=trial.error,
        room=trial.room or DEFAULT_ROOM,
    )


def _get_or_create_session(s: Session, subject_id: str, label: str, now: float) -> SessionRow:
    if s.get(Subject, subject_id) is None:
        s.add(Subject(id=subject_id, created_at=now))
        s.flush()
    row = s.get(SessionRow, f"{subject_id}/{label}")
    if row is None:
        row = SessionRow(id=f"{subject_id}/{label}", subject_id=subject_id, created_at=now)
        s.add(row)
        s.flush()
    return row


def session_label(session_id: str) -> str:
    return session_id.split("/", 1)[1] if "/" in session_id else session_id


def current_recording(catalog: Catalog, room: str = DEFAULT_ROOM) -> TrialInfo | None:
    """The trial that is recording now in ``room``, if any."""
    with catalog.reading() as s:
        trial = s.scalars(select(Trial).where(Trial.recording_slot == slot_of(s, room))).first()
        return None if trial is None else _info(trial, session_label(trial.session_id))


def start_trial(
    catalog: Catalog, *, subject_id: str, session: str, recording_path_for=None,
    calibration_id: str | None = None, trial_id: str | None = None, room: str = DEFAULT_ROOM,
) -> TrialInfo:
    """Create a trial in state ``recording`` in ``room`` (registered: :mod:`~gaitcap.services.catalog.rooms`).
    Raises RecordingBusy if another trial is recording there.

    ``recording_path_for(trial_id) -> str`` gives where the MCAP goes (stored in the row).
    """
    validate_id(subject_id, field="subject_id")
    validate_id(session, field="session")
    check_room(room)
    trial_id = validate_id(trial_id, field="trial_id") if trial_id else new_trial_id()
    now = time.time()
    try:
        with catalog.session() as s:
            slot = slot_of(s, room)
            busy = s.scalars(select(Trial.id).where(Trial.recording_slot == slot)).first()
            if busy is not None:
                raise RecordingBusy(busy, room)
            sess = _get_or_create_session(s, subject_id, session, now)
            trial = Trial(
                id=trial_id, session_id=sess.id, subject_id=subject_id, state=TrialState.RECORDING.value,
                room=room, recording_slot=slot, created_at=now, updated_at=now, started_at=now,
                recording_path=str(recording_path_for(trial_id)) if recording_path_for else "",
                calibration_id=calibration_id, stage="recording", progress=0.0, error="",
            )
            s.add(trial)
            s.flush()
            return _info(trial, session)
    except IntegrityError as exc:  # lost a race for the recording slot (or the id exists)
        busy = current_recording(catalog, room)
        if busy is None:
            raise ValueError(f"trial_id: {trial_id} already exists") from exc
        raise RecordingBusy(busy.id, room) from exc


def get_trial(catalog: Catalog, trial_id: str) -> TrialInfo:
    validate_id(trial_id, field="trial_id")
    with catalog.reading() as s:
        trial = s.get(Trial, trial_id)
        if trial is None:
            raise TrialNotFound(f"trial {trial_id} not found")
        return _info(trial, session_label(trial.session_id))


def list_trials(catalog: Catalog, *, subject_id: str | None = None, limit: int = 100,
                room: str | None = None) -> list[TrialInfo]:
    """Newest first; ``room``: only that room's (None: every room's)."""
    with catalog.reading() as s:
        q = select(Trial).order_by(Trial.created_at.desc()).limit(limit)
        if subject_id:
            q = q.where(Trial.subject_id == subject_id)
        if room is not None:
            q = q.where(Trial.room == check_room(room))
        return [_info(t, session_label(t.session_id)) for t in s.scalars(q)]


def set_state(
    catalog: Catalog, trial_id: str, new_state: str, *, expect: str | None = None, enqueue: bool = False,
    **fields,
) -> TrialInfo:
    """Move a trial along the state machine in ONE compare-and-set statement and update ``fields``.

    The ``UPDATE`` only matches while the trial is in a state from which ``new_state`` is allowed (and,
    with ``expect``, only in that state), so of several concurrent callers exactly one wins; the others
    get IllegalTransition naming the state they found. Leaving ``recording``/``stopping`` frees the
    recording slot. ``enqueue``: queue a processing job in the same transaction.
    """
    try:
        new = TrialState(new_state)
        sources = sources_of(new) if expect is None else sources_of(new) & {TrialState(expect)}
    except ValueError as exc:
        raise IllegalTransition(f"trial {trial_id}: unknown state in {expect!r} -> {new_state!r}") from exc
    for key in fields:
        if key in ("id", "state", "recording_slot") or not hasattr(Trial, key):
            raise ValueError(f"trial field {key!r} does not exist or cannot be set")
    now = time.time()
    values = {**fields, "state": new.value, "updated_at": now}
    if new not in HOLDS_SLOT:
        values["recording_slot"] = None
    with catalog.session() as s:
        changed = s.execute(
            update(Trial).where(Trial.id == trial_id, Trial.state.in_([x.value for x in sources]))
            .values(**values).execution_options(synchronize_session=False)
        ).rowcount
        trial = s.get(Trial, trial_id)
        if trial is None:
            raise TrialNotFound(f"trial {trial_id} not found")
        if changed != 1:
            if expect is not None and trial.state != expect:
                raise IllegalTransition(f"trial {trial_id}: is {trial.state}, expected {expect}")
            raise IllegalTransition(f"trial {trial_id}: cannot go from {trial.state} to {new.value}")
        if enqueue:
            s.add(new_job("process", trial_id=trial_id))
        return _info(trial, session_label(trial.session_id))


def set_progress(catalog: Catalog, trial_id: str, *, stage: str, progress: float) -> None:
    """Record the processing stage (words) and progress in [0, 1] without changing state."""
    with catalog.session() as s:
        trial = s.get(Trial, trial_id)
        if trial is None:
            raise TrialNotFound(f"trial {trial_id} not found")
        trial.stage, trial.progress, trial.updated_at = stage, float(progress), time.time()
