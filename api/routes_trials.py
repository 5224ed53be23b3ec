"""Trials: start, stop, list, show; the audit log."""

from __future__ import annotations

import logging
import time

from fastapi import APIRouter, Depends, HTTPException, Request
from fastapi.responses import JSONResponse
from gaitcap.api.auth import require_user
from gaitcap.api.deps import catalog_of, checked_id, checked_trial_id, trial_out, trials_out
from gaitcap.api.schemas import StartTrial, TrialOut
from gaitcap.api.subject_ids import check_subject_id
from gaitcap.reconstruction.calibration_io import rig_from_toml_text
from gaitcap.services import catalog as cat
from gaitcap.services.catalog.calibrations import current_board_recording
from gaitcap.services.live.health import disk_problem
from gaitcap.services.live.pending_stops import PendingStop, finish_stop
from gaitcap.services.live.protocols import RecorderUnavailable
from gaitcap.services.live.rig_check import NO_CAMERA, rig_problems
from gaitcap.services.processing.artifacts import trial_files
from sqlalchemy.exc import OperationalError

log = logging.getLogger(__name__)
router = APIRouter(tags=["trials"])


@router.post("/trials", status_code=201, response_model=TrialOut, summary="Start recording a trial")
def start(body: StartTrial, request: Request, user: str = Depends(require_user)) -> TrialOut:
    """Refused (409) when the rig is not fit to record (cameras the calibration needs are down, or far
    below the frame rate), unless ``override_rig_check`` confirms it (audited; a warning of the trial).
    A Start that fails part-way leaves no trial ``recording`` (it ends ``failed`` with the reason)."""
    db, settings, link = catalog_of(request), request.app.state.settings, request.app.state.link
    try:
        subject_id = check_subject_id(body.subject_id, settings.subject_id_pattern)
    except ValueError as exc:
        raise HTTPException(status_code=422, detail=str(exc)) from None
    if not getattr(link, "connected", True):
        raise HTTPException(status_code=503, detail="recorder: this server runs without the cameras and "
                                                    "recorder (started with --no-bus)")
    board = current_board_recording(db, settings.room)
    if board is not None:
        raise HTTPException(status_code=409, detail=f"board recording {board.id} is under way; stop it first")
    if low := disk_problem(settings.data_dir, int(settings.min_free_mb * 2**20)):  # nothing half-recorded
        raise HTTPException(status_code=409, detail=f"Start refused: {low}. Free space on it (move finished "
                                                    "trials off), then press Start again.")
    calibration = cat.latest_calibration(db, settings.room)
    problems = rig_problems(link.cameras(), _calibrated_cameras(calibration))
    if NO_CAMERA in problems:  # nothing to record: no confirmation starts a trial without images
        raise HTTPException(status_code=409, detail=f"Start refused: {NO_CAMERA}. Check the cameras' power and "
                                                    "network, then press Start again.")
    if problems and not body.override_rig_check:
        raise HTTPException(status_code=409, detail="Start refused: " + "; ".join(problems)
                            + ". To record anyway, confirm (override_rig_check).")
    trial_id = cat.new_trial_id()
    folder = trial_files(settings.data_dir, trial_id).root
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise HTTPException(status_code=507, detail=f"trials folder: cannot write {folder.parent} "
                                                    f"({exc.strerror or exc}); no trial was started") from None
    try:
        trial = cat.start_trial(
            db, subject_id=subject_id, session=body.session, trial_id=trial_id,
            recording_path_for=lambda tid: trial_files(settings.data_dir, tid).recording,
            calibration_id=calibration[0] if calibration else None, room=settings.room,
        )
    except cat.RecordingBusy as exc:
        folder.rmdir()
        raise HTTPException(status_code=409, detail=str(exc)) from None
    cat.audit(db, actor=user, action="start", trial_id=trial.id, detail=f"subject {trial.subject_id}")
    if problems:
        cat.audit(db, actor=user, action="start override", trial_id=trial.id, detail="; ".join(problems))
        cat.set_quality(db, trial.id, "start", {"by": user, "problems": problems,
                                                "warnings": [f"Started although {'; '.join(problems)}"]})
    _start_recorder(db, link, trial, calibration, user)
    return trial_out(db, trial)


def _calibrated_cameras(calibration: tuple[str, str] | None) -> list[str] | None:
    if calibration is None:
        return None
    try:
        return list(rig_from_toml_text(calibration[1], source=f"calibration {calibration[0]}").names)
    except (ValueError, KeyError, TypeError) as exc:
        raise HTTPException(status_code=409, detail=f"calibration {calibration[0]} in use does not load: {exc}") from None


def _start_recorder(db: cat.Catalog, link, trial: cat.TrialInfo, calibration, user: str) -> None:
    """Ask the recorder to start; on any failure the trial ends ``failed`` (never a phantom recording)."""
    metadata = {"trial_id": trial.id, "subject_id": trial.subject_id, "session": trial.session,
                "calibration_id": trial.calibration_id or "", "started_by": user}
    try:
        link.start(trial_id=trial.id, path=trial.recording_path, metadata=metadata,
                   calibration_toml=calibration[1] if calibration else None)
    except RecorderUnavailable as exc:
        _fail_start(db, trial, f"recorder: {exc}")
        raise HTTPException(status_code=503, detail=f"recorder: {exc}") from None
    except BaseException as exc:
        _fail_start(db, trial, f"start failed: {type(exc).__name__}: {exc}")
        raise


def _fail_start(db: cat.Catalog, trial: cat.TrialInfo, error: str) -> None:
    try:
        cat.set_state(db, trial.id, "failed", expect="recording", error=error, stage="", stopped_at=time.time())
    except cat.IllegalTransition:
        log.warning("trial %s: start failed (%s) but it had moved on meanwhile", trial.id, error)


@router.post("/trials/{trial_id}/stop", response_model=TrialOut, summary="Stop recording; queue processing")
def stop(trial_id: str, request: Request, user: str = Depends(require_user)) -> TrialOut:
    """Idempotent: of concurrent Stops exactly one (compare-and-set ``recording -> stopping``) closes the
    file and queues processing; the others, and any later Stop, get the trial as it is. 503 when the
    recorder does not answer: the trial is then ``interrupted`` and its recording recovered. 202 when the
    catalog is unreachable: the recorder stops (only the trial it records), the recording is saved and the
    Stop's catalog writes are retried until the catalog is back (:mod:`~gaitcap.services.live.pending_stops`)."""
    db, link = catalog_of(request), request.app.state.link
    trial_id = checked_trial_id(trial_id)
    try:
        trial = _get(db, trial_id)
    except OperationalError as exc:  # the catalog is unreachable: the recorder stops, the writes wait
        return _stop_without_catalog(request, trial_id, user, exc)
    if trial.room != request.app.state.settings.room:  # its cameras and recorder are another room's
        raise HTTPException(status_code=409, detail=f"trial {trial.id} records in room {trial.room or '(default)'}"
                                                    ": stop it from that room's page")
    try:
        trial = cat.set_state(db, trial.id, "stopping", expect="recording", stage="saving the recording")
    except cat.IllegalTransition:
        trial = _get(db, trial.id)
        if trial.state == "failed":
            raise HTTPException(status_code=409, detail=f"trial {trial.id} is failed: {trial.error}") from None
        return trial_out(db, trial)  # already stopped (or being stopped) by another request
    cat.audit(db, actor=user, action="stop", trial_id=trial.id)
    try:
        summary = link.stop(trial.id)
    except RecorderUnavailable as exc:
        reason = f"recorder: {exc}; the recording is kept and will be recovered"
        trial = cat.set_state(db, trial.id, "interrupted", expect="stopping", error=reason, stopped_at=time.time(),
                              stage="recovering the recording")
        raise HTTPException(status_code=503, detail=f"{reason} (trial {trial.id} is interrupted)") from None
    trial = finish_stop(db, trial, summary, stopped_at=time.time())
    log.info("trial %s stopped; processing queued", trial.id)
    return trial_out(db, trial)


def _stop_without_catalog(request: Request, trial_id: str, user: str, exc: OperationalError) -> JSONResponse:
    """Stop while the catalog is unreachable: only the trial this room's recorder records now is stopped
    (the recorder refuses any other), and its catalog writes wait in the app's PendingStops (202)."""
    link, pending = request.app.state.link, request.app.state.pending_stops
    try:
        summary = link.stop(trial_id)
    except RecorderUnavailable as unavailable:
        raise HTTPException(status_code=503, detail=f"the catalog is unreachable and the recorder: {unavailable}; "
                                                    "the recording goes on: try again") from None
    pending.add(PendingStop(trial_id=trial_id, summary=summary, actor=user, stopped_at=time.time()))
    words = str(exc.orig or exc).strip().splitlines()[0][:300]
    return JSONResponse(status_code=202, content={
        "id": trial_id, "state": "stopping", "catalog_unreachable": True,
        "detail": f"recording saved; the catalog is unreachable ({words}): the trial is written and queued for "
                  "processing as soon as it is back"})


@router.get("/trials", response_model=list[TrialOut], summary="Trials, newest first")
def list_trials(request: Request, subject_id: str | None = None, limit: int = 50, room: str | None = None,
                user: str = Depends(require_user)) -> list[TrialOut]:
    """``room``: only the trials recorded in that room ('' the default room; absent: every room's)."""
    if subject_id is not None:
        checked = checked_id(subject_id, field="subject_id").upper()  # ids match case-insensitively
        subject_id = checked
    if not 1 <= limit <= 1000:
        raise HTTPException(status_code=422, detail="limit: must be between 1 and 1000")
    db = catalog_of(request)
    return trials_out(db, cat.list_trials(db, subject_id=subject_id, limit=limit, room=room))


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
