"""Shared request helpers: the app's catalog, link and settings; converting rows for the API."""

from __future__ import annotations

from fastapi import HTTPException, Request
from gaitcap.api.schemas import STATE_WORDS, TrialOut
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import patients as pat


def catalog_of(request: Request) -> cat.Catalog:
    return request.app.state.catalog


def checked_id(value: str, *, field: str) -> str:
    """``value`` if it is a safe id, else 422 naming ``field`` (the one id check of every route)."""
    try:
        return cat.validate_id(value, field=field)
    except ValueError as exc:
        raise HTTPException(status_code=422, detail=str(exc)) from None


def checked_trial_id(trial_id: str) -> str:
    return checked_id(trial_id, field="trial_id")


def trial_out(db: cat.Catalog, t: cat.TrialInfo, stages: list[str] | None = None,
              quality: dict | None = None, details: pat.TrialDetailsInfo | None = None) -> TrialOut:
    text = STATE_WORDS.get(t.state, t.state)
    details = pat.get_details(db, t.id) if details is None else details
    if t.state == "processing" and t.stage:
        text = f"Processing: {t.stage}"
    return TrialOut(
        id=t.id, subject_id=t.subject_id, session=t.session, state=t.state, state_text=text,
        created_at=t.created_at, started_at=t.started_at, stopped_at=t.stopped_at, duration_s=t.duration_s,
        stage=t.stage, progress=t.progress, error=t.error,
        results=sorted(cat.stages_available(db, t.id) if stages is None else stages),
        warnings=cat.warnings_of(cat.get_quality(db, t.id) if quality is None else quality),
        voided=details.voided, void_reason=details.void_reason, room=t.room,
    )


def trials_out(db: cat.Catalog, trials: list[cat.TrialInfo],
               details: dict[str, pat.TrialDetailsInfo] | None = None) -> list[TrialOut]:
    """Several trials with their result stages, quality and void marks (one query each; ``details``:
    the trials' clinical fields when the caller has them, from :func:`pat.details_of`)."""
    ids = [t.id for t in trials]
    stages, quality = cat.stages_of(db, ids), cat.qualities_of(db, ids)
    details = pat.details_of(db, ids) if details is None else details
    return [trial_out(db, t, stages.get(t.id, []), quality.get(t.id, {}), details.get(t.id, pat.TrialDetailsInfo()))
            for t in trials]
