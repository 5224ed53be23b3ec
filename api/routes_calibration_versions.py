"""Calibration versions over HTTP: a calibration refined from people (``gaitcap refine-rig --data-dir``)
names the one it replaces, with its per-camera comparison; applying it queues the trials that used the old
one for processing again under it, through the worker's one processing path (the page's one button)."""

from __future__ import annotations

from fastapi import APIRouter, Depends, HTTPException, Request
from gaitcap.api.auth import require_user
from gaitcap.api.deps import catalog_of, checked_id
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import calibration_versions as versions

router = APIRouter(tags=["calibrations"])


def _version(db, cal_id: str) -> versions.VersionInfo:
    version = versions.get_version(db, checked_id(cal_id, field="cal_id"))
    if version is None:
        raise HTTPException(status_code=404, detail=f"calibration {cal_id} is no version: it replaces no other")
    return version


@router.get("/calibrations/{cal_id}/version", summary="What a calibration version replaces, and how far each camera moved")
def version_of(cal_id: str, request: Request, user: str = Depends(require_user)) -> dict:
    db = catalog_of(request)
    v = _version(db, cal_id)
    return {"id": v.calibration_id, "replaces": v.replaces_id, "made_by": v.made_by, "trials": list(v.trials),
            "comparison": v.comparison, "created_at": v.created_at, "applied_at": v.applied_at,
            "lineage": versions.lineage(db, cal_id), "trials_using_replaced": versions.trials_using(db, v.replaces_id)}


@router.post("/calibrations/{cal_id}/apply", summary="Reprocess the trials that used the calibration a version replaces")
def apply(cal_id: str, request: Request, user: str = Depends(require_user)) -> dict:
    db = catalog_of(request)
    _version(db, cal_id)
    queued, skipped = versions.apply_version(db, cal_id)
    cat.audit(db, actor=user, action="apply calibration", detail=f"{cal_id}: {len(queued)} trials queued")
    return {"id": cal_id, "queued": queued, "skipped": skipped}
