"""Calibrations, one router for every kind: upload one (made with ``gaitcap calibrate``), or record a
board sequence from the clinic (a worker computes it as a ``calibrate`` job); list them, show one with
its quality report, download it. One recording (trial or board) at a time: 409 otherwise."""

from __future__ import annotations

import logging
import time
import tomllib
from dataclasses import replace
from pathlib import Path

from fastapi import APIRouter, Depends, HTTPException, Request
from fastapi.responses import PlainTextResponse
from gaitcap.api.auth import require_user
from gaitcap.api.deps import catalog_of, checked_id
from gaitcap.api.schemas import BoardRecordingIn
from gaitcap.reconstruction.calibration_io import rig_from_toml_text, rig_to_toml_text
from gaitcap.reconstruction.camera import Rig
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import calibrations as cals
from gaitcap.services.live.protocols import RecorderUnavailable
from gaitcap.services.live.rig_check import calibration_problems
from gaitcap.services.processing.boards import check_board
from pydantic import BaseModel, ConfigDict, Field

log = logging.getLogger(__name__)
router = APIRouter(tags=["calibrations"])
SCENE_LEAD_S = 0.3  # the board appears this long after the recorder started: its floor frames are recorded
STATE_WORDS = {"recording": "Recording the board", "calibrating": "Calibrating", "done": "Done: active",
               "failed": "Failed"}


class CalibrationIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    toml: str = Field(min_length=1, max_length=1_000_000, description="aniposelib/Pose2Sim TOML (metres)")
    source: str = Field(default="", max_length=200, description="Where it came from (free text)")
    camera_map: dict[str, str] = Field(default_factory=dict, description="Calibration camera name -> the "
                                       "name of the camera in service, for calibrations made under other names")


def _out(c: cals.CalibrationInfo, active_id: str | None) -> dict:
    state_text = STATE_WORDS.get(c.state, c.state)
    if c.state == "done" and c.id != active_id:
        state_text = "Done (a newer calibration is active)"
    return {"id": c.id, "kind": c.kind, "state": c.state, "state_text": state_text, "created_at": c.created_at,
            "source": c.source, "started_at": c.started_at, "stopped_at": c.stopped_at, "started_by": c.started_by,
            "stage": c.stage, "progress": c.progress, "error": c.error, "active": c.id == active_id,
            "report": c.report, "has_toml": c.has_toml, "board": c.board}


def _room(request: Request) -> str:
    """The capture room this API runs: its rig's calibrations (gaitcap.services.catalog.rooms)."""
    return request.app.state.settings.room


def _active_id(db, room: str) -> str | None:
    latest = cat.latest_calibration(db, room)
    return latest[0] if latest else None


def _load(text: str, camera_map: dict[str, str]) -> tuple[Rig, dict, str]:
    """(rig with ``camera_map`` applied, TOML metadata, TOML text to store); 422 naming the problem."""
    try:
        rig = rig_from_toml_text(text, source="calibration")
        metadata = tomllib.loads(text).get("metadata", {})
        unknown = sorted(set(camera_map) - set(rig.names))
        if unknown:
            raise ValueError(f"camera_map: {', '.join(unknown)} not in the calibration (cameras: {rig.names})")
        if camera_map:
            rig = Rig(tuple(replace(c, name=camera_map.get(c.name, c.name)) for c in rig.cameras))
            text = rig_to_toml_text(rig, metadata=metadata)
    except (ValueError, KeyError, TypeError, tomllib.TOMLDecodeError) as exc:
        detail = str(exc) if str(exc).startswith("camera_map") else f"toml: {exc}"
        raise HTTPException(status_code=422, detail=detail) from None
    return rig, metadata, text


@router.post("/calibrations", status_code=201, summary="Store a calibration; later trials use the newest")
def add(body: CalibrationIn, request: Request, user: str = Depends(require_user)) -> dict:
    """Checked against the rig before it can be used: camera names and count must match the cameras in
    service (or be mapped with ``camera_map``), intrinsics plausible for the image size, the reprojection
    error present; a mismatch is refused (422) naming the cameras and fields."""
    rig, metadata, text = _load(body.toml, body.camera_map)
    in_service = [c.name for c in request.app.state.link.cameras()]
    problems = calibration_problems(rig, metadata=metadata, in_service=in_service)
    if problems:
        raise HTTPException(status_code=422, detail="; ".join(problems))
    db = catalog_of(request)
    cal_id = cat.add_calibration(db, toml=text, source=body.source or f"uploaded by {user}",
                                 room=_room(request))
    mapped = f", mapped {body.camera_map}" if body.camera_map else ""
    cat.audit(db, actor=user, action="calibrate", detail=f"{cal_id}: {len(rig.names)} cameras{mapped}")
    return {"id": cal_id, "cameras": list(rig.names), "checked_against_rig": bool(in_service)}


@router.get("/calibrations/latest", summary="The calibration the next trial will use")
def latest(request: Request, user: str = Depends(require_user)) -> dict:
    found = cat.latest_calibration(catalog_of(request), _room(request))
    if found is None:
        raise HTTPException(status_code=404, detail="no calibration stored yet")
    return {"id": found[0], "toml": found[1]}


@router.post("/calibrations/record/start", status_code=201, summary="Start recording a board sequence")
def record_start(request: Request, body: BoardRecordingIn | None = None, user: str = Depends(require_user)) -> dict:
    """The board filmed is recorded with it: ``board`` in the body, else the clinic's board (``gaitcap
    serve --board-file``), else none (the default board)."""
    db, settings, link = catalog_of(request), request.app.state.settings, request.app.state.link
    board = body.board.model_dump(mode="json", exclude_none=True) if body and body.board else settings.board
    if board is not None:
        try:
            check_board(board)
        except ValueError as exc:
            raise HTTPException(status_code=422, detail=f"board: {exc}") from None
    if not getattr(link, "connected", True):
        raise HTTPException(status_code=503, detail="recorder: this server runs without the cameras and "
                                                    "recorder (started with --no-bus)")
    folder = Path(settings.data_dir) / "calibrations"
    try:
        c = cals.start_board_recording(db, recording_path_for=lambda cid: folder / cid / "board.mcap", started_by=user,
                                       board=board, room=_room(request))
    except cals.CalibrationBusy as exc:
        raise HTTPException(status_code=409, detail=str(exc)) from None
    cat.audit(db, actor=user, action="calibrate start", detail=c.id)
    try:
        Path(c.recording_path).parent.mkdir(parents=True, exist_ok=True)
        link.start(trial_id=c.id, path=c.recording_path,
                   metadata={"kind": "calibration", "calibration_id": c.id, "started_by": user})
    except RecorderUnavailable as exc:
        cals.update_calibration(db, c.id, state="failed", stage="", error=f"recorder: {exc}")
        raise HTTPException(status_code=503, detail=f"recorder: {exc}") from None
    request.app.state.scene.show("board", start_ns=time.time_ns() + int(SCENE_LEAD_S * 1e9))
    link.watch_board(c.id, board)  # the detector nodes look for it: GET /calibrations/record/coverage
    return _out(cals.get_calibration(db, c.id), _active_id(db, _room(request)))


@router.post("/calibrations/record/stop", summary="Stop the board recording; a worker computes the calibration")
def record_stop(request: Request, user: str = Depends(require_user)) -> dict:
    db, link = catalog_of(request), request.app.state.link
    c = cals.current_board_recording(db, _room(request))
    if c is None:
        raise HTTPException(status_code=409, detail="no board recording is under way")
    request.app.state.scene.show("walker", start_ns=time.time_ns())
    link.unwatch_board(c.id)
    cat.audit(db, actor=user, action="calibrate stop", detail=c.id)
    try:
        summary = link.stop(c.id)
    except RecorderUnavailable as exc:
        cals.update_calibration(db, c.id, state="failed", stage="", stopped_at=time.time(), error=f"recorder: {exc}")
        raise HTTPException(status_code=503, detail=f"recorder: {exc}") from None
    try:
        c = cals.queue_calibration(db, c.id, frames=(summary or {}).get("frames"))
    except ValueError as exc:  # stopped by another request in the meantime
        raise HTTPException(status_code=409, detail=str(exc)) from None
    log.info("board recording %s stopped (%s); calibration job queued", c.id, summary)
    return _out(c, _active_id(db, _room(request)))


@router.get("/calibrations/record/coverage", summary="Where the board has been seen in the board recording under way")
def record_coverage(request: Request, user: str = Depends(require_user)) -> dict:
    """Per camera the views of the board in each cell of a 4 x 4 cutting of its image and the frames looked
    at, per pair of cameras the moments both saw it, and advice in words on where to move the board
    (gaitcap.services.live.board_coverage); 409 when no board recording is under way."""
    db, link = catalog_of(request), request.app.state.link
    c = cals.current_board_recording(db, _room(request))
    if c is None or c.state != "recording":
        raise HTTPException(status_code=409, detail="no board recording is under way")
    coverage = link.board_coverage(c.id, [cam.name for cam in link.cameras()])
    if coverage is None:
        raise HTTPException(status_code=503, detail=f"board recording {c.id}: its board views are not followed by "
                                                    "this server (started before it, or without the bus)")
    return {"id": c.id, **coverage}


@router.get("/calibrations", summary="Calibrations, newest first (board recordings and uploads)")
def list_all(request: Request, limit: int = 50, user: str = Depends(require_user)) -> list[dict]:
    if not 1 <= limit <= 1000:
        raise HTTPException(status_code=422, detail="limit: must be between 1 and 1000")
    db = catalog_of(request)
    active = _active_id(db, _room(request))
    return [_out(c, active) for c in cals.list_calibrations(db, limit=limit, room=_room(request))]


def _found(db, cal_id: str) -> cals.CalibrationInfo:
    try:
        return cals.get_calibration(db, checked_id(cal_id, field="calibration_id"))
    except cals.CalibrationNotFound:
        raise HTTPException(status_code=404, detail=f"calibration {cal_id} not found") from None


@router.get("/calibrations/{cal_id}", summary="One calibration with its quality report")
def show(cal_id: str, request: Request, user: str = Depends(require_user)) -> dict:
    db = catalog_of(request)
    return _out(_found(db, cal_id), _active_id(db, _room(request)))


@router.get("/calibrations/{cal_id}/toml", response_class=PlainTextResponse,
            summary="Download the calibration (aniposelib/Pose2Sim TOML, metres)")
def download(cal_id: str, request: Request, user: str = Depends(require_user)) -> PlainTextResponse:
    db = catalog_of(request)
    cal_id = _found(db, cal_id).id
    toml = cat.calibration_toml(db, cal_id)
    if not toml:
        raise HTTPException(status_code=404, detail=f"calibration {cal_id} has no result (yet)")
    cat.audit(db, actor=user, action="download", detail=f"calibration {cal_id}")
    return PlainTextResponse(toml, media_type="application/toml",
                             headers={"Content-Disposition": f'attachment; filename="{cal_id}.toml"'})
