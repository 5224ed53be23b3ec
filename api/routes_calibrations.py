"""Calibrations: upload one (made with ``gaitcap calibrate``) for the next trials, list them."""

from __future__ import annotations

import tomllib
from dataclasses import replace

from fastapi import APIRouter, Depends, HTTPException, Request
from gaitcap.api.auth import require_user
from gaitcap.api.deps import catalog_of
from gaitcap.reconstruction.calibration_io import rig_from_toml_text, rig_to_toml_text
from gaitcap.reconstruction.camera import Rig
from gaitcap.services import catalog as cat
from gaitcap.services.live.rig_check import calibration_problems
from pydantic import BaseModel, ConfigDict, Field

router = APIRouter(tags=["calibrations"])


class CalibrationIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    toml: str = Field(min_length=1, max_length=1_000_000, description="aniposelib/Pose2Sim TOML (metres)")
    source: str = Field(default="", max_length=200, description="Where it came from (free text)")
    camera_map: dict[str, str] = Field(default_factory=dict, description="Calibration camera name -> the "
                                       "name of the camera in service, for calibrations made under other names")


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
    cal_id = cat.add_calibration(db, toml=text, source=body.source or f"uploaded by {user}")
    mapped = f", mapped {body.camera_map}" if body.camera_map else ""
    cat.audit(db, actor=user, action="calibrate", detail=f"{cal_id}: {len(rig.names)} cameras{mapped}")
    return {"id": cal_id, "cameras": list(rig.names), "checked_against_rig": bool(in_service)}


@router.get("/calibrations/latest", summary="The calibration the next trial will use")
def latest(request: Request, user: str = Depends(require_user)) -> dict:
    found = cat.latest_calibration(catalog_of(request))
    if found is None:
        raise HTTPException(status_code=404, detail="no calibration stored yet")
    return {"id": found[0], "toml": found[1]}
