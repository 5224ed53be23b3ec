"""A trial's agreement with a lab's reference recording (``gaitcap validate``'s files in the trial's
``validation/`` folder): the result as JSON, the report as PDF, the CSV and the figures."""

from __future__ import annotations

import json
from enum import StrEnum
from pathlib import Path

from fastapi import APIRouter, Depends, HTTPException, Request
from fastapi.responses import FileResponse
from gaitcap.api.auth import require_user
from gaitcap.api.deps import catalog_of, checked_trial_id
from gaitcap.services import catalog as cat
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.validation.names import FILES, TRIAL_FOLDER
from gaitcap.services.validation.shown_rows import shown_validation

router = APIRouter(tags=["validation"])


class ValidationFile(StrEnum):
    pdf = "pdf"
    csv = "csv"
    bland_altman = "bland_altman"
    angles = "angles"


_MEDIA = {"pdf": "application/pdf", "csv": "text/csv", "bland_altman": "image/png", "angles": "image/png"}


def _path(request: Request, trial_id: str, key: str) -> Path:
    trial_id = checked_trial_id(trial_id)
    try:
        cat.get_trial(catalog_of(request), trial_id)
    except cat.TrialNotFound as exc:
        raise HTTPException(status_code=404, detail=str(exc)) from None
    path = trial_files(request.app.state.settings.data_dir, trial_id).root / TRIAL_FOLDER / FILES[key]
    if not path.is_file():
        what = "no validation" if key == "json" else f"no validation {key}"
        raise HTTPException(status_code=404, detail=f"trial {trial_id} has {what} (gaitcap validate writes it "
                                                    f"into the trial's {TRIAL_FOLDER}/ folder)")
    return path


@router.get("/trials/{trial_id}/validation", summary="Agreement with a reference recording (gaitcap validate)")
def validation(trial_id: str, request: Request, user: str = Depends(require_user)) -> dict:
    path = _path(request, trial_id, "json")
    cat.audit(catalog_of(request), actor=user, action="view", trial_id=trial_id, detail="validation")
    result = json.loads(path.read_text())
    return {**result, "shown": shown_validation(result)}  # the texts the page shows, rounded as the report does


@router.get("/trials/{trial_id}/validation/{name}", summary="The validation's report, CSV or figures")
def validation_file(trial_id: str, name: ValidationFile, request: Request, user: str = Depends(require_user)):
    path = _path(request, trial_id, name.value)
    cat.audit(catalog_of(request), actor=user, action="download", trial_id=trial_id, detail=f"validation {name.value}")
    return FileResponse(path, media_type=_MEDIA[name.value], filename=f"{trial_id}-{path.name}")
