"""Calibrate from the clinic: record a board sequence, compute the calibration (a separate process),
show its quality report, download it. One recording (trial or board) at a time: 409 otherwise."""

from __future__ import annotations

import logging
import time
from pathlib import Path

from fastapi import APIRouter, Depends, HTTPException, Request
from fastapi.responses import PlainTextResponse
from gaitcap.api.auth import require_user
from gaitcap.api.deps import catalog_of, checked_id
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import calibration_runs as runs
from gaitcap.services.live.protocols import RecorderUnavailable

log = logging.getLogger(__name__)
router = APIRouter(tags=["calibrations"])
SCENE_LEAD_S = 0.3  # the board appears this long after the recorder started: its floor frames are recorded
STATE_WORDS = {"recording": "Recording the board", "calibrating": "Calibrating", "done": "Done: active",
               "failed": "Failed"}


def _out(run: runs.CalibrationRunInfo, active_id: str | None) -> dict:
    state_text = STATE_WORDS.get(run.state, run.state)
    if run.state == "done" and run.id != active_id:
        state_text = "Done (a newer calibration is active)"
    return {"id": run.id, "kind": "board recording", "state": run.state, "state_text": state_text,
            "created_at": run.created_at, "started_at": run.started_at, "stopped_at": run.stopped_at,
            "started_by": run.started_by, "stage": run.stage, "progress": run.progress, "error": run.error,
            "active": run.id == active_id, "report": run.report, "has_toml": run.has_toml}


def _active_id(db) -> str | None:
    latest = cat.latest_calibration(db)
    return latest[0] if latest else None


def _show_scene(link, scene: str, start_ns: int) -> None:
    show = getattr(link, "show_scene", None)  # only the bus link can switch the simulated cameras
    if show is not None:
        show(scene, start_ns=start_ns)


def _current(db) -> runs.CalibrationRunInfo:
    run = runs.current_board_recording(db)
    if run is None:
        raise HTTPException(status_code=409, detail="no board recording is under way")
    return run


@router.post("/calibrations/record/start", status_code=201, summary="Start recording a board sequence")
def record_start(request: Request, user: str = Depends(require_user)) -> dict:
    db, settings, link = catalog_of(request), request.app.state.settings, request.app.state.link
    if not getattr(link, "connected", True):
        raise HTTPException(status_code=503, detail="recorder: this server runs without the cameras and "
                                                    "recorder (started with --no-bus)")
    folder = Path(settings.data_dir) / "calibrations"
    try:
        run = runs.start_calibration_run(db, recording_path_for=lambda rid: folder / rid / "board.mcap",
                                         started_by=user)
    except runs.CalibrationBusy as exc:
        raise HTTPException(status_code=409, detail=str(exc)) from None
    cat.audit(db, actor=user, action="calibrate start", detail=run.id)
    try:
        Path(run.recording_path).parent.mkdir(parents=True, exist_ok=True)
        link.start(trial_id=run.id, path=run.recording_path,
                   metadata={"kind": "calibration", "calibration_id": run.id, "started_by": user})
    except RecorderUnavailable as exc:
        runs.update_calibration_run(db, run.id, state="failed", stage="", error=f"recorder: {exc}")
        raise HTTPException(status_code=503, detail=f"recorder: {exc}") from None
    _show_scene(link, "board", time.time_ns() + int(SCENE_LEAD_S * 1e9))
    return _out(runs.get_calibration_run(db, run.id), _active_id(db))


@router.post("/calibrations/record/stop", summary="Stop the board recording; the calibration is computed")
def record_stop(request: Request, user: str = Depends(require_user)) -> dict:
    from gaitcap.services.processing.calibration_job import launch

    db, settings, link = catalog_of(request), request.app.state.settings, request.app.state.link
    run = _current(db)
    _show_scene(link, "walker", time.time_ns())
    cat.audit(db, actor=user, action="calibrate stop", detail=run.id)
    try:
        summary = link.stop(run.id)
    except RecorderUnavailable as exc:
        runs.update_calibration_run(db, run.id, state="failed", stage="", stopped_at=time.time(),
                                    error=f"recorder: {exc}")
        raise HTTPException(status_code=503, detail=f"recorder: {exc}") from None
    run = runs.update_calibration_run(db, run.id, expect="recording", state="calibrating", stopped_at=time.time(),
                                      stage="waiting to calibrate", progress=0.0)
    launch(settings.catalog_url, run.id, expected_images=(summary or {}).get("frames"))
    log.info("board recording %s stopped (%s); calibrating", run.id, summary)
    return _out(run, _active_id(db))


@router.get("/calibrations", summary="Calibrations, newest first (board recordings and uploads)")
def list_all(request: Request, limit: int = 50, user: str = Depends(require_user)) -> list[dict]:
    if not 1 <= limit <= 1000:
        raise HTTPException(status_code=422, detail="limit: must be between 1 and 1000")
    db = catalog_of(request)
    active = _active_id(db)
    out = [_out(r, active) for r in runs.list_calibration_runs(db, limit=limit)]
    out += [{"id": cid, "kind": "uploaded", "state": "done", "state_text": "Done: active" if cid == active else
             "Done", "created_at": at, "source": source, "active": cid == active, "report": {}, "has_toml": True}
            for cid, at, source in runs.uploaded_calibrations(db, limit=limit)]
    return sorted(out, key=lambda c: c["created_at"], reverse=True)[:limit]


@router.get("/calibrations/{cal_id}", summary="One calibration with its quality report")
def show(cal_id: str, request: Request, user: str = Depends(require_user)) -> dict:
    db = catalog_of(request)
    try:
        return _out(runs.get_calibration_run(db, checked_id(cal_id, field="calibration_id")), _active_id(db))
    except runs.CalibrationNotFound:
        pass
    try:
        cat.get_calibration(db, cal_id)
    except KeyError:
        raise HTTPException(status_code=404, detail=f"calibration {cal_id} not found") from None
    active = _active_id(db)
    return {"id": cal_id, "kind": "uploaded", "state": "done", "active": cal_id == active, "report": {},
            "has_toml": True}


@router.get("/calibrations/{cal_id}/toml", response_class=PlainTextResponse,
            summary="Download the calibration (aniposelib/Pose2Sim TOML, metres)")
def download(cal_id: str, request: Request, user: str = Depends(require_user)) -> PlainTextResponse:
    db = catalog_of(request)
    cal_id = checked_id(cal_id, field="calibration_id")
    try:
        toml = runs.calibration_run_toml(db, cal_id)
    except runs.CalibrationNotFound:
        try:
            toml = cat.get_calibration(db, cal_id)
        except KeyError:
            raise HTTPException(status_code=404, detail=f"calibration {cal_id} not found") from None
    if not toml:
        raise HTTPException(status_code=404, detail=f"calibration {cal_id} has no result (yet)")
    cat.audit(db, actor=user, action="download", detail=f"calibration {cal_id}")
    return PlainTextResponse(toml, media_type="application/toml",
                             headers={"Content-Disposition": f'attachment; filename="{cal_id}.toml"'})
