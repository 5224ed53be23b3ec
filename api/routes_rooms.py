"""The capture rooms sharing this catalog: each room's rig state as its own API last wrote it (HTTP only;
:mod:`gaitcap.services.catalog.rooms`, :mod:`gaitcap.services.live.room_report`)."""

from __future__ import annotations

import time

from fastapi import APIRouter, Depends, Request
from gaitcap.api.auth import require_user
from gaitcap.api.deps import catalog_of
from gaitcap.services import catalog as cat
from gaitcap.services.catalog.rig_checks import latest_rig_check
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
    rig_check: dict | None = Field(None, description="The room's latest rig check: trial_id, checked_at (UNIX s), "
                                                     "flagged, moved (camera names); None before its first")


def _rig_check(db, room: str) -> dict | None:
    found = latest_rig_check(db, room=room)
    return None if found is None else {k: found[k] for k in ("trial_id", "checked_at", "flagged", "moved")}


@router.get("/rooms", response_model=list[RoomOut], summary="The capture rooms and each one's rig state")
def rooms(request: Request, user: str = Depends(require_user)) -> list[RoomOut]:
    now, own, db = time.time(), request.app.state.settings.room, catalog_of(request)
    return [RoomOut(name=r.name, host=r.host, this_room=r.name == own, seen_s_ago=round(max(0.0, now - r.seen_at), 1),
                    recording=r.recording, cameras_healthy=int(r.rig.get("healthy", 0)),
                    cameras_seen=int(r.rig.get("seen", 0)), cameras=list(r.rig.get("cameras", [])),
                    rig_check=_rig_check(db, r.name))
            for r in cat.list_rooms(db)]
