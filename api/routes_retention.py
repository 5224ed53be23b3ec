"""Retention: voiding a trial (admin) removes its files and its catalog rows; the audit keeps who, when, why."""

from __future__ import annotations

from fastapi import APIRouter, Depends, HTTPException, Request
from gaitcap.api.auth import client_ip, require_user
from gaitcap.api.deps import catalog_of, checked_trial_id
from gaitcap.services import catalog as cat
from gaitcap.services.catalog.retention import delete_trial_rows
from gaitcap.services.processing.artifacts import remove_trial_files, trial_files
from pydantic import BaseModel, Field

router = APIRouter(tags=["retention"])


class VoidIn(BaseModel):
    reason: str = Field(min_length=5, max_length=500, description="Why the trial is removed (audited).")


@router.post("/trials/{trial_id}/void", summary="Remove a trial's files and results for good (admin; audited)")
def void(trial_id: str, body: VoidIn, request: Request, user: str = Depends(require_user)) -> dict:
    db = catalog_of(request)
    try:
        trial = cat.get_trial(db, checked_trial_id(trial_id))
    except cat.TrialNotFound:
        raise HTTPException(status_code=404, detail=f"trial {trial_id} does not exist") from None
    if trial.state in ("recording", "processing"):
        raise HTTPException(status_code=409, detail=f"trial {trial.id} is {trial.state}; stop or wait first")
    left = remove_trial_files(trial_files(request.app.state.settings.data_dir, trial.id, trial.recording_path))
    if left:  # the rows stay, so the files are still found and the void can be retried
        raise HTTPException(status_code=500, detail=f"trial {trial.id}: could not remove {[str(p) for p in left]}; "
                                                    "its catalog rows are kept, try again")
    rows = delete_trial_rows(db, trial.id)
    cat.audit(db, actor=user, action="void", trial_id=trial.id, detail=body.reason)
    request.app.state.audit_chain.record(actor=user, action="void", target=trial.id, detail=body.reason,
                                         ip=client_ip(request))
    return {"voided": trial.id, "files_removed": True, "catalog_rows": rows}
