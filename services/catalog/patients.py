"""Patients as records (the pseudonymous subject with sex, birth year and notes), a trial's clinical
fields (operator, walking aid, assistance, footwear, notes), correcting a trial's patient or session,
and voiding a trial (kept, with the reason, left out of the history). Callers audit the changes."""

from __future__ import annotations

import time
from dataclasses import dataclass, fields

from gaitcap.services.catalog.db import Catalog
from gaitcap.services.catalog.ids import validate_id
from gaitcap.services.catalog.models import PatientDetails, SessionRow, Subject, Trial, TrialDetails
from gaitcap.services.catalog.trials import TrialInfo, TrialNotFound, session_label
from sqlalchemy import func, select

SEXES = ("", "female", "male")


class PatientNotFound(KeyError):
    """No patient with that id."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "patient not found"


class TrialAlreadyVoid(ValueError):
    """The trial is already marked void (marking it again is a conflict, not bad input)."""


class VoidReasonMissing(ValueError):
    """A void mark without a reason (at least 5 characters)."""


@dataclass(frozen=True)
class PatientInfo:
    """A patient: id (upper case), when first seen (UNIX s), sex, birth year, notes, number of trials."""

    id: str
    created_at: float
    sex: str = ""
    birth_year: int | None = None
    notes: str = ""
    trials: int = 0


def age_at_trial(patient: PatientInfo, trial: TrialInfo) -> int | None:
    """The patient's age in whole years at the trial (when it started, else when it was created; by
    calendar year, UTC, as only the birth year is recorded); None without a birth year. The one age of a
    patient at a trial: the norms, the kinematics' band, the report and the history all use it."""
    if patient.birth_year is None:
        return None
    return time.gmtime(trial.started_at or trial.created_at).tm_year - patient.birth_year


@dataclass(frozen=True)
class TrialDetailsInfo:
    """A trial's clinical fields and void mark (``voided_at`` None: not voided)."""

    operator: str = ""
    walking_aid: str = ""
    assistance: str = ""
    footwear: str = ""
    notes: str = ""
    voided_at: float | None = None
    voided_by: str = ""
    void_reason: str = ""

    @property
    def voided(self) -> bool:
        return self.voided_at is not None


DETAIL_FIELDS = ("operator", "walking_aid", "assistance", "footwear", "notes")


def _patient(row: Subject, details: PatientDetails | None, trials: int) -> PatientInfo:
    if details is None:
        return PatientInfo(row.id, row.created_at, trials=trials)
    return PatientInfo(row.id, row.created_at, details.sex, details.birth_year, details.notes, trials)


def ensure_patient(catalog: Catalog, subject_id: str) -> PatientInfo:
    """The patient ``subject_id`` (upper case), created if new."""
    pid = validate_id(subject_id, field="subject_id").upper()
    with catalog.session() as s:
        row = s.get(Subject, pid)
        if row is None:
            row = Subject(id=pid, created_at=time.time())
            s.add(row)
            s.flush()
        count = s.scalar(select(func.count()).select_from(Trial).where(Trial.subject_id == pid)) or 0
        return _patient(row, s.get(PatientDetails, pid), int(count))


def get_patient(catalog: Catalog, subject_id: str) -> PatientInfo:
    pid = validate_id(subject_id, field="subject_id").upper()
    with catalog.reading() as s:
        row = s.get(Subject, pid)
        if row is None:
            raise PatientNotFound(f"patient {pid} not found")
        count = s.scalar(select(func.count()).select_from(Trial).where(Trial.subject_id == pid)) or 0
        return _patient(row, s.get(PatientDetails, pid), int(count))


def list_patients(catalog: Catalog, *, prefix: str = "", limit: int = 200) -> list[PatientInfo]:
    """Patients whose id starts with ``prefix`` (case-insensitive), most recently seen first."""
    with catalog.reading() as s:
        last = (select(Trial.subject_id, func.max(Trial.created_at).label("last"), func.count().label("n"))
                .group_by(Trial.subject_id).subquery())
        q = (select(Subject, PatientDetails, last.c.n).outerjoin(PatientDetails, PatientDetails.subject_id == Subject.id)
             .outerjoin(last, last.c.subject_id == Subject.id)
             .order_by(func.coalesce(last.c.last, Subject.created_at).desc()).limit(limit))
        if prefix:
            q = q.where(Subject.id.like(prefix.upper().replace("%", "").replace("_", "\\_") + "%", escape="\\"))
        return [_patient(subj, det, int(n or 0)) for subj, det, n in s.execute(q)]


def update_patient(catalog: Catalog, subject_id: str, *, sex: str | None = None, birth_year: int | None = None,
                   notes: str | None = None) -> tuple[PatientInfo, dict]:
    """Set the given fields; returns the patient and ``{field: (old, new)}`` of what changed."""
    if sex is not None and sex not in SEXES:
        raise ValueError(f"sex: must be one of {', '.join(repr(x) for x in SEXES)}")
    this_year = time.gmtime().tm_year
    if birth_year is not None and not this_year - 120 <= birth_year <= this_year:
        raise ValueError(f"birth_year: {birth_year} is not between {this_year - 120} and {this_year}")
    pid = get_patient(catalog, subject_id).id
    changes: dict = {}
    with catalog.session() as s:
        row = s.get(PatientDetails, pid) or PatientDetails(subject_id=pid, sex="", birth_year=None, notes="")
        for key, value in (("sex", sex), ("birth_year", birth_year), ("notes", notes)):
            if value is not None and getattr(row, key) != value:
                changes[key] = (getattr(row, key), value)
                setattr(row, key, value)
        row.updated_at = time.time()
        s.merge(row)
    return get_patient(catalog, pid), changes


def get_details(catalog: Catalog, trial_id: str) -> TrialDetailsInfo:
    """The trial's clinical fields (all empty when none were entered)."""
    return details_of(catalog, [trial_id]).get(trial_id, TrialDetailsInfo())


def details_of(catalog: Catalog, trial_ids: list[str]) -> dict[str, TrialDetailsInfo]:
    """trial id -> clinical fields, for the trials that have any (one query)."""
    names = [f.name for f in fields(TrialDetailsInfo)]
    with catalog.reading() as s:
        rows = s.scalars(select(TrialDetails).where(TrialDetails.trial_id.in_(trial_ids)))
        return {r.trial_id: TrialDetailsInfo(**{n: getattr(r, n) for n in names}) for r in rows}


def _details_row(s, trial_id: str) -> TrialDetails:
    if s.get(Trial, trial_id) is None:
        raise TrialNotFound(f"trial {trial_id} not found")
    row = s.get(TrialDetails, trial_id)
    if row is None:
        row = TrialDetails(trial_id=trial_id, operator="", walking_aid="", assistance="", footwear="", notes="",
                           voided_by="", void_reason="", updated_at=time.time())
        s.add(row)
    return row


def correct_trial(catalog: Catalog, trial_id: str, *, subject_id: str | None = None, session: str | None = None,
                  **details: str) -> dict:
    """Correct a trial's patient, session and clinical fields (``DETAIL_FIELDS``); returns
    ``{field: (old, new)}`` of what changed (for the audit). A new patient or session is created."""
    unknown = sorted(set(details) - set(DETAIL_FIELDS))
    if unknown:
        raise ValueError(f"{unknown[0]}: not a trial field (fields: {', '.join(DETAIL_FIELDS)})")
    changes: dict = {}
    now = time.time()
    with catalog.session() as s:
        trial = s.get(Trial, trial_id)
        if trial is None:
            raise TrialNotFound(f"trial {trial_id} not found")
        new_subject = trial.subject_id if subject_id is None else validate_id(subject_id, field="subject_id").upper()
        old_label = session_label(trial.session_id)
        new_label = old_label if session is None else validate_id(session, field="session")
        if (new_subject, new_label) != (trial.subject_id, old_label):
            if s.get(Subject, new_subject) is None:
                s.add(Subject(id=new_subject, created_at=now))
            sid = f"{new_subject}/{new_label}"
            if s.get(SessionRow, sid) is None:
                s.add(SessionRow(id=sid, subject_id=new_subject, created_at=now))
            s.flush()
            for key, old, new in (("subject_id", trial.subject_id, new_subject), ("session", old_label, new_label)):
                if old != new:
                    changes[key] = (old, new)
            trial.subject_id, trial.session_id, trial.updated_at = new_subject, sid, now
        row = _details_row(s, trial_id)
        for key, value in details.items():
            if value is not None and getattr(row, key) != value:
                changes[key] = (getattr(row, key), value)
                setattr(row, key, value)
        row.updated_at = now
    return changes


def void_trial(catalog: Catalog, trial_id: str, *, by: str, reason: str) -> TrialDetailsInfo:
    """Mark the trial void (kept, with who, when and why; left out of the history). VoidReasonMissing when
    the reason is too short, TrialAlreadyVoid when the trial is already void (both ValueErrors)."""
    reason = reason.strip()
    if len(reason) < 5:
        raise VoidReasonMissing("reason: say why the trial is void (at least 5 characters)")
    with catalog.session() as s:
        row = _details_row(s, trial_id)
        if row.voided_at is not None:
            raise TrialAlreadyVoid(f"trial {trial_id} is already void ({row.void_reason})")
        row.voided_at, row.voided_by, row.void_reason, row.updated_at = time.time(), by[:128], reason[:2000], time.time()
    return get_details(catalog, trial_id)
