"""Live views: a status WebSocket (trials, camera health), JPEG previews (WebSocket and MJPEG)."""

from __future__ import annotations

import asyncio
import json
import logging
import time

from fastapi import APIRouter, Depends, HTTPException, Request, WebSocket, WebSocketDisconnect
from fastapi.responses import Response, StreamingResponse
from gaitcap.api.auth import require_user, websocket_user
from gaitcap.api.deps import checked_id, trials_out
from gaitcap.api.schemas import CameraOut
from gaitcap.services import catalog as cat
from starlette.concurrency import run_in_threadpool

log = logging.getLogger(__name__)
router = APIRouter(tags=["live"])
BOUNDARY = "gaitcapframe"


def _camera_dicts(link) -> list[dict]:
    return [CameraOut(name=c.name, fps=round(c.fps, 1), healthy=c.healthy, status=c.status,
                      age_s=round(c.age_s, 2)).model_dump() for c in link.cameras()]


def status_snapshot(app) -> dict:
    """What the page shows live: the recording trial, recent trials with states, camera health, and the live
    detection coverage per camera (frames received, detected, skipped, lost, failed; lag s)."""
    db, room = app.state.catalog, app.state.settings.room
    trials = [t.model_dump() for t in trials_out(db, cat.list_trials(db, limit=20, room=room))]  # this room's
    recording = next((t for t in trials if t["state"] == "recording"), None)
    return {"time": time.time(), "room": room, "recording": recording, "trials": trials, "cameras": _camera_dicts(app.state.link),
            "detection": app.state.link.detection()}


@router.get("/cameras", response_model=list[CameraOut], summary="Camera health (fps, status)")
def cameras(request: Request, user: str = Depends(require_user)):
    return _camera_dicts(request.app.state.link)


@router.get("/status", summary="The live status snapshot (same as the status WebSocket sends)")
def status(request: Request, user: str = Depends(require_user)):
    return status_snapshot(request.app)


@router.websocket("/ws/status")
async def status_ws(ws: WebSocket) -> None:
    """Sends the status snapshot as JSON every ``status_period_s`` (0.5 s). Signed in by the session cookie."""
    if websocket_user(ws) is None:
        await ws.close(code=1008, reason="not signed in, not allowed or wrong Origin")
        return
    await ws.accept()
    period = ws.app.state.settings.status_period_s
    try:
        while True:
            snap = await run_in_threadpool(status_snapshot, ws.app)
            await ws.send_text(json.dumps(snap))
            await asyncio.sleep(period)
    except (WebSocketDisconnect, RuntimeError):
        return


@router.websocket("/ws/preview")
async def preview_ws(ws: WebSocket, fps: float = 5.0) -> None:
    """Binary messages, one per new preview frame: 1 byte name length, the camera name, the JPEG."""
    if websocket_user(ws) is None:
        await ws.close(code=1008, reason="not signed in, not allowed or wrong Origin")
        return
    await ws.accept()
    link, period = ws.app.state.link, 1.0 / max(0.5, min(fps, 30.0))
    sent: dict[str, float] = {}
    try:
        while True:
            for cam in link.cameras():
                frame = link.preview(cam.name)
                if frame is None or sent.get(cam.name) == frame[0]:
                    continue
                sent[cam.name] = frame[0]
                name = cam.name.encode()[:255]
                await ws.send_bytes(bytes([len(name)]) + name + frame[1])
            await asyncio.sleep(period)
    except (WebSocketDisconnect, RuntimeError):
        return


@router.get("/cameras/{name}/preview.jpg", summary="The newest preview frame of one camera")
def preview_jpg(name: str, request: Request, user: str = Depends(require_user)):
    frame = request.app.state.link.preview(checked_id(name, field="camera"))
    if frame is None:
        raise HTTPException(status_code=404, detail=f"camera {name}: no preview frame")
    return Response(frame[1], media_type="image/jpeg")


@router.get("/cameras/{name}/preview.mjpg", summary="Multipart MJPEG preview stream of one camera")
async def preview_mjpeg(name: str, request: Request, fps: float = 5.0, user: str = Depends(require_user)):
    link, cam, period = request.app.state.link, checked_id(name, field="camera"), 1.0 / max(0.5, min(fps, 30.0))

    async def frames():
        last = None
        while not await request.is_disconnected():
            frame = link.preview(cam)
            if frame is not None and frame[0] != last:
                last = frame[0]
                yield (f"--{BOUNDARY}\r\nContent-Type: image/jpeg\r\nContent-Length: {len(frame[1])}\r\n\r\n"
                       .encode() + frame[1] + b"\r\n")
            await asyncio.sleep(period)

    return StreamingResponse(frames(), media_type=f"multipart/x-mixed-replace; boundary={BOUNDARY}")
