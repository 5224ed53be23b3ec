"""The capture rooms sharing this catalog: each room's rig state as its own API last wrote it (HTTP only;
:mod:`gaitcap.services.catalog.rooms`, :mod:`gaitcap.services.live.room_report`)."""

from __future__ import annotations

import time

from fastapi import APIRouter, Depends, Request
from gaitcap.api.auth import require_user
from gaitcap.api.deps import catalog_of
from gaitcap.services import catalog as cat
from pydantic import BaseModel, Field

router = APIRouter(tags=["rooms"])


class RoomOut(BaseModel):
    name: str = Field(description="The room's name ('' the default room of a one-room clinic)")
    host: str = Field(description="The host its stack runs on")
    this_room: bool = Field(description="The room this API runs (its Start and Stop)")
    seen_s_ago: float = Field(description="How long ago the room last wrote its rig state (s)")
    recording: str | None = Field(description="The trial recording there now")
    cameras_healthy: int = Field(description="Cameras delivering at full rate when last seen")
    cameras_seen: int = Field(description="Cameras seen on the room's bus when last seen")
    cameras: list[dict] = Field(default_factory=list, description="Each camera: name, fps, healthy, status")


@router.get("/rooms", response_model=list[RoomOut], summary="The capture rooms and each one's rig state")
def rooms(request: Request, user: str = Depends(require_user)) -> list[RoomOut]:
    now, own = time.time(), request.app.state.settings.room
    return [RoomOut(name=r.name, host=r.host, this_room=r.name == own, seen_s_ago=round(max(0.0, now - r.seen_at), 1),
                    recording=r.recording, cameras_healthy=int(r.rig.get("healthy", 0)),
                    cameras_seen=int(r.rig.get("seen", 0)), cameras=list(r.rig.get("cameras", [])))
            for r in cat.list_rooms(catalog_of(request))]
