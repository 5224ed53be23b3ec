"""Joint kinematics of a trial: gait-cycle curves with norms and key values (JSON, CSV, PNG) and the model files
(MOT angles, scaled OSIM model, the fitted markers as TRC, trajectories and gait events as C3D)."""

from __future__ import annotations

import json
from enum import StrEnum

from fastapi import APIRouter, Depends, HTTPException, Request
from fastapi.responses import FileResponse, Response
from gaitcap.api.auth import require_user
from gaitcap.api.deps import catalog_of
from gaitcap.api.routes_results import Stage, _attachment, _result
from gaitcap.services import catalog as cat
from gaitcap.services.processing.artifacts import trial_files

router = APIRouter(tags=["results"])


class KinematicsFormat(StrEnum):
    json = "json"
    csv = "csv"
    png = "png"
    mot = "mot"
    osim = "osim"
    trc = "trc"
    c3d = "c3d"


# format -> (artifact key, media type, download suffix)
_FILES = {
    KinematicsFormat.csv: ("kinematics_csv", "text/csv", "kinematics.csv"),
    KinematicsFormat.png: ("kinematics_png", "image/png", "kinematics.png"),
    KinematicsFormat.mot: ("kinematics_mot", "text/plain", "kinematics.mot"),
    KinematicsFormat.osim: ("kinematics_osim", "application/xml", "model.osim"),
    KinematicsFormat.trc: ("kinematics_trc", "text/plain", "markers.trc"),
    KinematicsFormat.c3d: ("trajectory_c3d", "application/octet-stream", "trajectory.c3d"),
}


# formats made, when asked for, from the JSON with the band chosen for the patient (shown.SHOWN_FORMATS)
_SHOWN = (KinematicsFormat.json, KinematicsFormat.csv, KinematicsFormat.png)


def _status(request: Request, trial_id: str, stage: str) -> dict:
    """The stage's kinematics.json, or 404 saying why there is none (engine missing, not computed yet)."""
    path = trial_files(request.app.state.settings.data_dir, trial_id).stage_file(stage, "kinematics_json")
    if path.is_file():
        return json.loads(path.read_text())
    from gaitcap.services.kinematics import availability

    ok, reason = availability()
    detail = (f"trial {trial_id}: {stage} kinematics not computed (yet)" if ok
              else f"kinematics are unavailable on this server: {reason}")
    raise HTTPException(status_code=404, detail=detail)


def _key_value_norms(status: dict) -> dict:
    """Key value name -> its label (with the sign convention), normal value (deg), SD where read (None for a
    range of motion), the percent of the cycle, the normal range (mean +- 1.96 SD, None without an SD) and,
    for a range of motion, its one-sided ``lower_limit_deg``, from the band shown. Without a normal value:
    ``no_reference``, the sentence to show (no band for this patient, or the angle's zero not validated)."""
    from gaitcap.reconstruction.jsonable import finite_or_none
    from gaitcap.reconstruction.kinematics.clinical import key_label
    from gaitcap.reconstruction.kinematics.key_norms import KEY_VALUES, key_norms, no_reference
    from gaitcap.services.reports.shown import key_norm_shown

    norms = status.get("norms") or {}
    patient = norms.get("no_reference")
    out = {name: {"label": key_label(name), "normal_deg": None, "sd_deg": None, "at_pct": None,
                  "normal_range_deg": None, "lower_limit_deg": None,
                  "no_reference": "no reference for this patient" if patient else no_reference(name),
                  "shown": {"normal": None, "normal_range": None, "lower_limit": None}}
           for name in KEY_VALUES}
    for name, n in key_norms(norms.get("bands") or {}).items():
        band = n.band()
        out[name] = {"label": key_label(name), "normal_deg": finite_or_none(n.normal_deg),
                     "sd_deg": finite_or_none(n.sd_deg), "at_pct": n.at_pct,
                     "normal_range_deg": [round(band[0], 2), round(band[1], 2)] if band else None,
                     "lower_limit_deg": finite_or_none(round(n.lower_deg, 2)), "no_reference": None,
                     "shown": key_norm_shown(n)}
    return out


@router.get("/trials/{trial_id}/kinematics",
            summary="Joint angles over the gait cycle with norms and key values (JSON, CSV), model files")
def kinematics(trial_id: str, request: Request, stage: Stage | None = None,
               format: KinematicsFormat = KinematicsFormat.json, user: str = Depends(require_user)):
    r = _result(request, trial_id, stage)
    cat.audit(catalog_of(request), actor=user, action="download" if format is not KinematicsFormat.json else "view",
              trial_id=r.trial_id, detail=f"kinematics {r.stage} {format.value}")
    from gaitcap.services.kinematics.shown import SHOWN_FORMATS, patient_age, with_norms

    status = _status(request, r.trial_id, r.stage)
    if format in _SHOWN:  # the band by the patient's age now (a birth year may be recorded after the fit)
        status = with_norms(status, patient_age(catalog_of(request), r.trial_id))
    if format is KinematicsFormat.json:
        from gaitcap.reconstruction.kinematics.gait_profile import gait_profile
        from gaitcap.reconstruction.kinematics.key_norms import key_norms
        from gaitcap.services.reports.shown import key_values_shown

        bands = (status.get("norms") or {}).get("bands") or {}
        extra = {"key_value_norms": _key_value_norms(status),
                 "key_values_shown": key_values_shown(status.get("key_values"), key_norms(bands)),
                 "gait_profile": gait_profile(status).to_dict()
                 if status.get("curves") and (status.get("norms") or {}).get("bands") else None}  # no band: none
        return {"trial_id": r.trial_id, "stage": r.stage, **status, **extra}
    if not status.get("available", False):
        raise HTTPException(status_code=404, detail=f"trial {r.trial_id}: no kinematics: {status.get('reason', '')}")
    key, media, suffix = _FILES[format]
    if format in _SHOWN:
        return Response(SHOWN_FORMATS[format.value](status), media_type=media,
                        headers=_attachment(f"{r.trial_id}-{r.stage}-{suffix}"))
    path = trial_files(request.app.state.settings.data_dir, r.trial_id).stage_file(r.stage, key)
    if not path.is_file():
        raise HTTPException(status_code=404, detail=f"trial {r.trial_id}: {r.stage} {key} not available")
    return FileResponse(path, media_type=media, filename=f"{r.trial_id}-{r.stage}-{suffix}")
