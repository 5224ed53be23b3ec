"""The rig check of the latest processed trial, for the page's calibration section: did a camera move
since calibration (named, with its rotation deg and shift mm), shown before the next patient."""

from __future__ import annotations

from fastapi import APIRouter, Depends, HTTPException, Request
from gaitcap.api.auth import require_user
from gaitcap.api.deps import catalog_of
from gaitcap.services.catalog.rig_checks import latest_rig_check

router = APIRouter(tags=["calibrations"])


@router.get("/rig-check/latest", summary="The latest processed trial's rig check (cameras moved since calibration)")
def rig_check_latest(request: Request, room: str | None = None, user: str = Depends(require_user)) -> dict:
    """The latest of room ``room``'s trials (absent: this API's own room; '' the default room); 404 when no
    processed trial of that room has run a rig check yet."""
    own = request.app.state.settings.room
    found = latest_rig_check(catalog_of(request), room=own if room is None else room)
    if found is None:
        raise HTTPException(status_code=404, detail="no processed trial has checked the rig yet")
    return found
