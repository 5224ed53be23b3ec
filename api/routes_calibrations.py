"""Calibrations: upload one (made with ``gaitcap calibrate``) for the next trials, list them."""

from __future__ import annotations

import tempfile
from pathlib import Path

from fastapi import APIRouter, Depends, HTTPException, Request
from gaitcap.api.auth import require_user
from gaitcap.api.deps import catalog_of
from gaitcap.reconstruction.calibration_io import load_rig
from gaitcap.services import catalog as cat
from pydantic import BaseModel, ConfigDict, Field

router = APIRouter(tags=["calibrations"])


class CalibrationIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    toml: str = Field(min_length=1, max_length=1_000_000, description="aniposelib/Pose2Sim TOML (metres)")
    source: str = Field(default="", max_length=200, description="Where it came from (free text)")


def _check_toml(text: str) -> list[str]:
    """Camera names of a calibration TOML; 422 naming the problem when it does not load."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "calibration.toml"
        path.write_text(text)
        try:
            return list(load_rig(path).names)
        except (ValueError, KeyError, TypeError) as exc:
            raise HTTPException(status_code=422, detail=f"toml: {exc}".replace(str(path), "calibration")) from None


@router.post("/calibrations", status_code=201, summary="Store a calibration; later trials use the newest")
def add(body: CalibrationIn, request: Request, user: str = Depends(require_user)) -> dict:
    cameras = _check_toml(body.toml)
    db = catalog_of(request)
    cal_id = cat.add_calibration(db, toml=body.toml, source=body.source or f"uploaded by {user}")
    cat.audit(db, actor=user, action="calibrate", detail=f"{cal_id}: {len(cameras)} cameras")
    return {"id": cal_id, "cameras": cameras}


@router.get("/calibrations/latest", summary="The calibration the next trial will use")
def latest(request: Request, user: str = Depends(require_user)) -> dict:
    found = cat.latest_calibration(catalog_of(request))
    if found is None:
        raise HTTPException(status_code=404, detail="no calibration stored yet")
    return {"id": found[0], "toml": found[1]}
