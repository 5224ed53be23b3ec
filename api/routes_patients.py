"""Patients as records (case-insensitive pseudonymous id, first seen, sex and birth year for the norms,
notes) with their history, and trial corrections and voiding (both audited with the old and new values)."""

from __future__ import annotations

import math

from fastapi import APIRouter, Depends, HTTPException, Request
from gaitcap.api.auth import require_user
from gaitcap.api.deps import catalog_of, checked_id, checked_trial_id, trials_out
from gaitcap.api.subject_ids import check_subject_id
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import patients as pat
from gaitcap.services.catalog.ids import ID_PATTERN
from gaitcap.services.reports.content import NORM_UNITS, PARAMETERS, ReportConfig
from gaitcap.services.reports.norms import NormsError, NormTable, load_norms
from gaitcap.services.reports.shown import SUMMARY_DECIMALS, shown
from pydantic import BaseModel, ConfigDict, Field

router = APIRouter(tags=["patients"])
TREND = (("gait_speed_m_per_s", "gait_speed_m_s"), ("cadence_steps_per_min", "cadence_steps_min"),
         ("step_length_mm", "step_length_mm"), ("step_length_asymmetry_pct", "step_length_symmetry_index_pct"))
#: decimals of the trend values as shown (the report's parameters'; the symmetry index as the summary's)
TREND_DECIMALS = {name: PARAMETERS[name].decimals if name in PARAMETERS else SUMMARY_DECIMALS[key]
                  for key, name in TREND}


class PatientIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    sex: str | None = Field(default=None, description="female, male or empty (for the normative comparison)")
    birth_year: int | None = Field(default=None, description="Year of birth (age decade for the norms)")
    notes: str | None = Field(default=None, max_length=2000)


class TrialCorrection(BaseModel):
    """Fields to correct; those left out stay as they are."""

    model_config = ConfigDict(extra="forbid")
    subject_id: str | None = Field(default=None, pattern=ID_PATTERN, description="The right patient id")
    session: str | None = Field(default=None, pattern=ID_PATTERN, description="The right session label")
    operator: str | None = Field(default=None, max_length=128)
    walking_aid: str | None = Field(default=None, max_length=128, description="e.g. none, cane, walker")
    assistance: str | None = Field(default=None, max_length=128, description="e.g. none, standby, hand held")
    footwear: str | None = Field(default=None, max_length=128, description="e.g. own shoes, barefoot")
    notes: str | None = Field(default=None, max_length=2000)
    reason: str = Field(min_length=1, max_length=500, pattern=r"\S", description="Why (required; audited)")


class VoidIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    reason: str = Field(min_length=5, max_length=500, description="Why the trial is void (audited)")


def _patient_out(p: pat.PatientInfo) -> dict:
    return {"id": p.id, "created_at": p.created_at, "sex": p.sex, "birth_year": p.birth_year, "notes": p.notes,
            "trials": p.trials}


def _patient(request: Request, subject_id: str) -> pat.PatientInfo:
    try:
        return pat.get_patient(catalog_of(request), checked_id(subject_id, field="subject_id"))
    except pat.PatientNotFound as exc:
        raise HTTPException(status_code=404, detail=str(exc)) from None


@router.get("/patients", summary="Patients, most recently seen first")
def list_patients(request: Request, prefix: str = "", limit: int = 200, user: str = Depends(require_user)) -> list[dict]:
    if prefix:
        checked_id(prefix, field="prefix")
    return [_patient_out(p) for p in pat.list_patients(catalog_of(request), prefix=prefix,
                                                         limit=max(1, min(limit, 1000)))]


@router.get("/patients/{subject_id}", summary="A patient with every trial by visit and the key values")
def show_patient(subject_id: str, request: Request, user: str = Depends(require_user)) -> dict:
    """``history``: oldest first, each with the trial, its void mark and clinical fields, ``values`` (gait
    speed m/s, cadence steps/min, step length mm, step-length symmetry index %) of its best result and
    ``normal_ranges`` (the same names -> [low, high], mean -+ 1.96 SD for the patient's sex and age at that
    trial; a name without a normative row is left out), and ``shown``: both as the page writes them
    (``values``: name -> text, ``normal_ranges``: name -> [low, high] texts; the one rounding rule,
    :mod:`gaitcap.services.reports.shown`)."""
    db, p = catalog_of(request), _patient(request, subject_id)
    out = history_of(db, p, _norms())
    cat.audit(db, actor=user, action="view", detail=f"patient {p.id}")
    return {**_patient_out(p), "history": out}


def history_of(db: cat.Catalog, p: pat.PatientInfo, norms: NormTable) -> list[dict]:
    """The patient's trials oldest first as ``show_patient`` returns them; a fixed number of queries
    (the trials, then their stages, quality, clinical fields and best results each in one)."""
    trials = list(reversed(cat.list_trials(db, subject_id=p.id, limit=1000)))
    ids = [t.id for t in trials]
    details, means = pat.details_of(db, ids), cat.best_means_of(db, ids)
    out = []
    for t, t_out in zip(trials, trials_out(db, trials, details), strict=True):
        values = {name: means.get(t.id, {}).get(key) for key, name in TREND}
        values = {k: v for k, v in values.items() if isinstance(v, float) and math.isfinite(v)}
        bands = _bands(norms, p, t)
        d = details.get(t.id, pat.TrialDetailsInfo())
        out.append({**t_out.model_dump(), "voided": d.voided, "void_reason": d.void_reason,
                    "walking_aid": d.walking_aid, "assistance": d.assistance, "footwear": d.footwear,
                    "operator": d.operator, "notes": d.notes, "values": values,
                    "normal_ranges": {name: [round(x, 4) for x in band] for name, band in bands.items()},
                    "shown": {"values": {k: shown(v, TREND_DECIMALS[k]) for k, v in values.items()},
                              "normal_ranges": {name: [shown(x, TREND_DECIMALS[name]) for x in band]
                                                for name, band in bands.items()}}})
    return out


@router.put("/patients/{subject_id}", summary="Set a patient's sex, birth year or notes (audited)")
def update_patient(subject_id: str, body: PatientIn, request: Request, user: str = Depends(require_user)) -> dict:
    db = catalog_of(request)
    try:
        pid = check_subject_id(subject_id, request.app.state.settings.subject_id_pattern)
    except ValueError as exc:
        raise HTTPException(status_code=422, detail=str(exc)) from None
    pat.ensure_patient(db, pid)
    p, changes = pat.update_patient(db, pid, sex=body.sex, birth_year=body.birth_year, notes=body.notes)
    if changes:
        cat.audit(db, actor=user, action="patient edit", detail=f"patient {p.id}: " + _changes(changes))
    return _patient_out(p)


@router.post("/trials/{trial_id}/correct", summary="Correct a trial's patient, session or clinical fields (audited)")
def correct(trial_id: str, body: TrialCorrection, request: Request, user: str = Depends(require_user)) -> dict:
    db = catalog_of(request)
    trial_id = checked_trial_id(trial_id)
    fields = body.model_dump(exclude={"reason", "subject_id", "session"}, exclude_none=True)
    subject_id = body.subject_id
    if subject_id is not None:
        try:
            subject_id = check_subject_id(subject_id, request.app.state.settings.subject_id_pattern)
        except ValueError as exc:
            raise HTTPException(status_code=422, detail=str(exc)) from None
    try:
        changes = pat.correct_trial(db, trial_id, subject_id=subject_id, session=body.session, **fields)
    except cat.TrialNotFound as exc:
        raise HTTPException(status_code=404, detail=str(exc)) from None
    if changes:
        cat.audit(db, actor=user, action="correct", trial_id=trial_id,
                  detail=_changes(changes) + (f" (reason: {body.reason})" if body.reason else ""))
    return {"trial_id": trial_id, "changed": {k: {"old": o, "new": n} for k, (o, n) in changes.items()}}


@router.post("/trials/{trial_id}/mark-void", summary="Mark a trial void with a reason (kept; audited)")
def mark_void(trial_id: str, body: VoidIn, request: Request, user: str = Depends(require_user)) -> dict:
    """The trial and its files stay (struck through, with the reason, on the page and the report) and it
    is left out of the patient's trends and comparisons. 409 when it is already void."""
    db = catalog_of(request)
    trial_id = checked_trial_id(trial_id)
    try:
        d = pat.void_trial(db, trial_id, by=user, reason=body.reason)
    except cat.TrialNotFound as exc:
        raise HTTPException(status_code=404, detail=str(exc)) from None
    except pat.TrialAlreadyVoid as exc:
        raise HTTPException(status_code=409, detail=str(exc)) from None
    except pat.VoidReasonMissing as exc:
        raise HTTPException(status_code=422, detail=str(exc)) from None
    cat.audit(db, actor=user, action="mark void", trial_id=trial_id, detail=body.reason)
    return {"trial_id": trial_id, "voided_at": d.voided_at, "voided_by": d.voided_by, "void_reason": d.void_reason}


def _norms() -> NormTable:
    try:
        return load_norms(ReportConfig.from_env().norms_csv, units=NORM_UNITS)
    except NormsError as exc:
        raise HTTPException(status_code=500, detail=f"the normative table (GAITCAP_NORMS_CSV): {exc}") from None


def _bands(norms: NormTable, p: pat.PatientInfo, trial: cat.TrialInfo) -> dict[str, tuple[float, float]]:
    """Trend name -> the normal range (low, high) for the patient's sex and age at ``trial``."""
    age = pat.age_at_trial(p, trial)
    rows = {name: norms.find(name, sex=p.sex, age=age) for _, name in TREND}
    return {name: row.band() for name, row in rows.items() if row is not None}


def _changes(changes: dict) -> str:
    return "; ".join(f"{k}: {o!r} -> {n!r}" for k, (o, n) in changes.items())
