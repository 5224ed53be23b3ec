"""Trials: start, stop, list, show; the audit log."""

from __future__ import annotations

import logging
import time

from fastapi import APIRouter, Depends, HTTPException, Request
from gaitcap.api.auth import require_user
from gaitcap.api.deps import catalog_of, checked_trial_id, trial_out, trials_out
from gaitcap.api.schemas import StartTrial, TrialOut
from gaitcap.services import catalog as cat
from gaitcap.services.catalog.calibration_runs import current_board_recording
from gaitcap.services.live.protocols import RecorderUnavailable
from gaitcap.services.processing.artifacts import trial_files

log = logging.getLogger(__name__)
router = APIRouter(tags=["trials"])


@router.post("/trials", status_code=201, response_model=TrialOut, summary="Start recording a trial")
def start(body: StartTrial, request: Request, user: str = Depends(require_user)) -> TrialOut:
    db, settings, link = catalog_of(request), request.app.state.settings, request.app.state.link
    if not getattr(link, "connected", True):
        raise HTTPException(status_code=503, detail="recorder: this server runs without the cameras and "
                                                    "recorder (started with --no-bus)")
    board = current_board_recording(db)
    if board is not None:
        raise HTTPException(status_code=409, detail=f"board recording {board.id} is under way; stop it first")
    calibration = cat.latest_calibration(db)
    try:
        trial = cat.start_trial(
            db, subject_id=body.subject_id, session=body.session,
            recording_path_for=lambda tid: trial_files(settings.data_dir, tid).recording,
            calibration_id=calibration[0] if calibration else None,
        )
    except cat.RecordingBusy as exc:
        raise HTTPException(status_code=409, detail=str(exc)) from None
    cat.audit(db, actor=user, action="start", trial_id=trial.id, detail=f"subject {trial.subject_id}")
    metadata = {"trial_id": trial.id, "subject_id": trial.subject_id, "session": trial.session,
                "calibration_id": trial.calibration_id or "", "started_by": user,
                "calibration_toml": calibration[1] if calibration else ""}
    try:
        trial_files(settings.data_dir, trial.id).root.mkdir(parents=True, exist_ok=True)
        link.start(trial_id=trial.id, path=trial.recording_path, metadata=metadata)
    except RecorderUnavailable as exc:
        cat.set_state(db, trial.id, "failed", error=f"recorder: {exc}", stage="")
        raise HTTPException(status_code=503, detail=f"recorder: {exc}") from None
    return trial_out(db, trial)


@router.post("/trials/{trial_id}/stop", response_model=TrialOut, summary="Stop recording; queue processing")
def stop(trial_id: str, request: Request, user: str = Depends(require_user)) -> TrialOut:
    db, link = catalog_of(request), request.app.state.link
    trial = _get(db, checked_trial_id(trial_id))
    if trial.state != "recording":
        raise HTTPException(status_code=409, detail=f"trial {trial.id} is {trial.state}, not recording")
    cat.audit(db, actor=user, action="stop", trial_id=trial.id)
    try:
        summary = link.stop(trial.id)
    except RecorderUnavailable as exc:
        cat.set_state(db, trial.id, "failed", error=f"recorder: {exc}", stopped_at=time.time(), stage="")
        raise HTTPException(status_code=503, detail=f"recorder: {exc}") from None
    try:
        trial = cat.set_state(db, trial.id, "recorded", expect="recording", stopped_at=time.time(),
                              stage="waiting for a worker", progress=0.0)
    except cat.IllegalTransition as exc:
        raise HTTPException(status_code=409, detail=str(exc)) from None
    cat.enqueue_job(db, trial.id)
    log.info("trial %s stopped (%s); processing queued", trial.id, summary)
    return trial_out(db, trial)


@router.get("/trials", response_model=list[TrialOut], summary="Trials, newest first")
def list_trials(request: Request, subject_id: str | None = None, limit: int = 50,
                user: str = Depends(require_user)) -> list[TrialOut]:
    if subject_id is not None:
        checked = _validated(subject_id, "subject_id")
        subject_id = checked
    if not 1 <= limit <= 1000:
        raise HTTPException(status_code=422, detail="limit: must be between 1 and 1000")
    db = catalog_of(request)
    return trials_out(db, cat.list_trials(db, subject_id=subject_id, limit=limit))


@router.get("/trials/{trial_id}", response_model=TrialOut, summary="One trial")
def show(trial_id: str, request: Request, user: str = Depends(require_user)) -> TrialOut:
    db = catalog_of(request)
    trial = _get(db, checked_trial_id(trial_id))
    cat.audit(db, actor=user, action="view", trial_id=trial.id)
    return trial_out(db, trial)


@router.get("/audit", summary="The audit log, newest first")
def audit_log(request: Request, trial_id: str | None = None, limit: int = 200,
              user: str = Depends(require_user)) -> list[dict]:
    if trial_id is not None:
        checked_trial_id(trial_id)
    rows = cat.audit_entries(catalog_of(request), trial_id=trial_id, limit=max(1, min(limit, 5000)))
    return [e.__dict__ for e in rows]


def _get(db: cat.Catalog, trial_id: str) -> cat.TrialInfo:
    try:
        return cat.get_trial(db, trial_id)
    except cat.TrialNotFound as exc:
        raise HTTPException(status_code=404, detail=str(exc)) from None


def _validated(value: str, field: str) -> str:
    try:
        return cat.validate_id(value, field=field)
    except ValueError as exc:
        raise HTTPException(status_code=422, detail=str(exc)) from None
