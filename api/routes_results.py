"""Results and downloads: gait metrics, steps, trajectory, the recording, the report plot, the .rrd and
the results MCAP (for Rerun and Foxglove)."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path

from fastapi import APIRouter, Depends, HTTPException, Request
from fastapi.responses import FileResponse, PlainTextResponse
from gaitcap.api.auth import require_user
from gaitcap.api.deps import catalog_of, checked_trial_id
from gaitcap.api.exports import steps_csv, trajectory_csv, trajectory_json
from gaitcap.api.schemas import GaitOut
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import patients as pat
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.reports.content import PARAMETERS, sides_of, stored_gait
from gaitcap.services.reports.findings import consistency_of
from gaitcap.services.reports.shown import summary_shown

router = APIRouter(tags=["results"])


class Stage(StrEnum):
    preliminary = "preliminary"
    refined = "refined"


class TableFormat(StrEnum):
    json = "json"
    csv = "csv"


class TrajectoryFormat(StrEnum):
    json = "json"
    csv = "csv"
    trc = "trc"


def _result(request: Request, trial_id: str, stage: Stage | None) -> cat.ResultInfo:
    db = catalog_of(request)
    trial_id = checked_trial_id(trial_id)
    try:
        cat.get_trial(db, trial_id)
    except cat.TrialNotFound as exc:
        raise HTTPException(status_code=404, detail=str(exc)) from None
    result = cat.get_result(db, trial_id, stage.value if stage else None)
    if result is None:
        what = f"{stage.value} results" if stage else "results"
        raise HTTPException(status_code=404, detail=f"trial {trial_id} has no {what} yet")
    return result


def _file(request: Request, trial_id: str, stage: str, key: str) -> Path:
    path = trial_files(request.app.state.settings.data_dir, trial_id).stage_file(stage, key)
    if not path.is_file():
        raise HTTPException(status_code=404, detail=f"trial {trial_id}: {stage} {key} not available")
    return path


def _downloads(trial_id: str, stage: str) -> dict[str, str]:
    base = f"/trials/{trial_id}"
    return {
        "steps_csv": f"{base}/steps?format=csv&stage={stage}",
        "trajectory_csv": f"{base}/trajectory?format=csv&stage={stage}",
        "trajectory_trc": f"{base}/trajectory?format=trc&stage={stage}",
        "trajectory_json": f"{base}/trajectory?format=json&stage={stage}",
        "report_png": f"{base}/report.png?stage={stage}",
        "rerun_rrd": f"{base}/rerun.rrd?stage={stage}",
        "results_mcap": f"{base}/results.mcap?stage={stage}",
        "recording_mcap": f"{base}/recording",
    }


@router.get("/trials/{trial_id}/gait", response_model=GaitOut, summary="Gait metrics (best stage by default)")
def gait(trial_id: str, request: Request, stage: Stage | None = None, user: str = Depends(require_user)):
    r = _result(request, trial_id, stage)
    cat.audit(catalog_of(request), actor=user, action="view", trial_id=r.trial_id, detail=f"gait {r.stage}")
    gait_json = stored_gait(request.app.state.settings.data_dir, r.trial_id, r.stage)
    data_quality = r.report.get("data_quality") or {}
    return GaitOut(trial_id=r.trial_id, stage=r.stage, method=r.method, elapsed_s=r.elapsed_s, **_void(request, r.trial_id),
                   consistency=consistency_of(r.report.get("consistency") or r.quality.get("consistency")
                                              or (gait_json or {}).get("consistency"),
                                              gait_json or {"summary": r.summary, "steps": r.steps}, data_quality),
                   summary=r.summary, steps=r.steps, quality=r.quality,
                   shown=summary_shown(r.summary, {name: p.decimals for name, p in PARAMETERS.items()}),
                   downloads=_downloads(r.trial_id, r.stage),
                   warnings=cat.warnings_of(cat.get_quality(catalog_of(request), r.trial_id)),
                   data_quality=r.report.get("data_quality", {}),
                   sides=sides_of((gait_json or {}).get("summary", {})),
                   analysis_warnings=list(r.report.get("warnings") or []),
                   findings=_findings(request, r.trial_id, r.stage))


def _findings(request: Request, trial_id: str, stage: str) -> dict:
    """The stage's findings as its report makes them ({} without a gait file)."""
    from gaitcap.services.reports.content import ReportConfig, stage_findings
    from gaitcap.services.reports.norms import NormsError

    try:
        said = stage_findings(catalog_of(request), request.app.state.settings.data_dir, trial_id, stage,
                              ReportConfig.from_env())
    except NormsError as exc:
        raise HTTPException(status_code=500, detail=f"the normative table (GAITCAP_NORMS_CSV): {exc}") from None
    return said.to_dict() if said is not None else {}


@router.get("/trials/{trial_id}/steps", summary="Per-step parameters (JSON or CSV)")
def steps(trial_id: str, request: Request, stage: Stage | None = None, format: TableFormat = TableFormat.json,
          user: str = Depends(require_user)):
    r = _result(request, trial_id, stage)
    cat.audit(catalog_of(request), actor=user, action="download", trial_id=r.trial_id,
              detail=f"steps {r.stage} {format.value}")
    void = _void(request, r.trial_id)
    if format is TableFormat.csv:
        warnings = cat.warnings_of(cat.get_quality(catalog_of(request), r.trial_id))
        return PlainTextResponse(steps_csv(r.steps, warnings, void_reason=void["void_reason"] if void["voided"] else None),
                                 media_type="text/csv", headers=_attachment(f"{r.trial_id}-{r.stage}-steps.csv"))
    return {"trial_id": r.trial_id, "stage": r.stage, **void, "steps": r.steps}


def _void(request: Request, trial_id: str) -> dict:
    """``voided`` and ``void_reason`` of the trial (every export says whether it is void)."""
    d = pat.get_details(catalog_of(request), trial_id)
    return {"voided": d.voided, "void_reason": d.void_reason}


@router.get("/trials/{trial_id}/trajectory", summary="3D joint trajectories in mm (JSON, CSV or TRC)")
def trajectory(trial_id: str, request: Request, stage: Stage | None = None,
               format: TrajectoryFormat = TrajectoryFormat.json, user: str = Depends(require_user)):
    r = _result(request, trial_id, stage)
    cat.audit(catalog_of(request), actor=user, action="download", trial_id=r.trial_id,
              detail=f"trajectory {r.stage} {format.value}")
    if format is TrajectoryFormat.trc:
        path = _file(request, r.trial_id, r.stage, "trajectory_trc")
        return FileResponse(path, media_type="text/plain", filename=f"{r.trial_id}-{r.stage}.trc")
    npz = _file(request, r.trial_id, r.stage, "trajectory_npz")
    if format is TrajectoryFormat.csv:
        return PlainTextResponse(trajectory_csv(npz), media_type="text/csv",
                                 headers=_attachment(f"{r.trial_id}-{r.stage}-trajectory.csv"))
    return {"trial_id": r.trial_id, "stage": r.stage, **trajectory_json(npz)}


@router.get("/trials/{trial_id}/report.png", summary="The gait report plot (heel traces and steps)")
def report_png(trial_id: str, request: Request, stage: Stage | None = None, user: str = Depends(require_user)):
    r = _result(request, trial_id, stage)
    cat.audit(catalog_of(request), actor=user, action="download", trial_id=r.trial_id, detail=f"report {r.stage}")
    return FileResponse(_file(request, r.trial_id, r.stage, "report_png"), media_type="image/png")


@router.get("/trials/{trial_id}/rerun.rrd", summary="The 3D reconstruction for the Rerun viewer")
def rerun(trial_id: str, request: Request, stage: Stage | None = None, user: str = Depends(require_user)):
    r = _result(request, trial_id, stage)
    cat.audit(catalog_of(request), actor=user, action="download", trial_id=r.trial_id, detail=f"rrd {r.stage}")
    return FileResponse(_file(request, r.trial_id, r.stage, "rerun_rrd"), media_type="application/octet-stream",
                        filename=f"{r.trial_id}-{r.stage}.rrd")


@router.get("/trials/{trial_id}/results.mcap", summary="The results for Foxglove (skeleton, rig, gait events)")
def results_mcap(trial_id: str, request: Request, stage: Stage | None = None, user: str = Depends(require_user)):
    r = _result(request, trial_id, stage)
    cat.audit(catalog_of(request), actor=user, action="download", trial_id=r.trial_id, detail=f"results mcap {r.stage}")
    return FileResponse(_file(request, r.trial_id, r.stage, "results_mcap"), media_type="application/octet-stream",
                        filename=f"{r.trial_id}-{r.stage}-results.mcap")


@router.get("/trials/{trial_id}/recording", summary="The trial's MCAP recording")
def recording(trial_id: str, request: Request, user: str = Depends(require_user)):
    db = catalog_of(request)
    trial_id = checked_trial_id(trial_id)
    try:
        trial = cat.get_trial(db, trial_id)
    except cat.TrialNotFound as exc:
        raise HTTPException(status_code=404, detail=str(exc)) from None
    if trial.state == "recording":
        raise HTTPException(status_code=409, detail=f"trial {trial_id} is still recording")
    path = Path(trial.recording_path)  # where the catalog records it (the one source of a trial's files)
    if not trial.recording_path or not path.is_file():
        raise HTTPException(status_code=404, detail=f"trial {trial_id}: recording file not found")
    cat.audit(db, actor=user, action="download", trial_id=trial_id, detail="recording")
    return FileResponse(path, media_type="application/octet-stream", filename=f"{trial_id}.mcap")


def _attachment(name: str) -> dict[str, str]:
    return {"Content-Disposition": f'attachment; filename="{name}"'}
