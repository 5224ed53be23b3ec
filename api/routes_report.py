"""The clinical report of a trial: the PDF for the chart and the same numbers as JSON for the page
(both sides, symmetry, the normative range and z-score, flags, the previous visit)."""

from __future__ import annotations

import math

from fastapi import APIRouter, Depends, HTTPException, Request
from fastapi.responses import Response
from gaitcap.api.auth import require_user
from gaitcap.api.deps import catalog_of, checked_trial_id
from gaitcap.services import catalog as cat
from gaitcap.services.catalog.patients import DETAIL_FIELDS
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.reports.content import (
    PARAMETERS,
    ReportConfig,
    ReportContent,
    report_content,
    stored_gait,
)
from gaitcap.services.reports.figures import heel_traces
from gaitcap.services.reports.norms import NormsError
from gaitcap.services.reports.shown import shown, shown_signed

router = APIRouter(tags=["report"])


def _content(request: Request, trial_id: str) -> ReportContent:
    db = catalog_of(request)
    try:
        return report_content(db, request.app.state.settings.data_dir, checked_trial_id(trial_id),
                              ReportConfig.from_env())
    except cat.TrialNotFound as exc:
        raise HTTPException(status_code=404, detail=str(exc)) from None
    except FileNotFoundError as exc:
        raise HTTPException(status_code=404, detail=str(exc)) from None
    except NormsError as exc:
        raise HTTPException(status_code=500, detail=f"the normative table (GAITCAP_NORMS_CSV): {exc}") from None


def _num(x: float, decimals: int) -> float | None:
    return round(x, decimals) if math.isfinite(x) else None


def _shown(r, c: ReportContent) -> dict:
    """The row's numbers as the page, the print and the PDF show them (one rounding rule:
    services/reports/shown.py); None where not measured."""
    d, band = PARAMETERS[r.name].decimals, r.norm.band() if r.norm is not None else None
    return {"left": shown(r.left, d), "right": shown(r.right, d), "mean": shown(r.mean, d), "sd": shown(r.sd, d + 1),
            "cv_pct": shown(r.cv_pct, 1), "symmetry_index_pct": shown(r.si_pct, 1), "z": shown_signed(r.z, 1),
            "normal_range": [shown(band[0], d), shown(band[1], d)] if band else None,
            "previous": shown(c.previous.values.get(r.name, math.nan), d) if c.previous else None}


@router.get("/trials/{trial_id}/report.pdf", summary="The trial's report for the patient's chart (PDF)")
def report_pdf(trial_id: str, request: Request, user: str = Depends(require_user)) -> Response:
    c = _content(request, trial_id)
    from gaitcap.services.reports.pdf import report_pdf as render  # fpdf2 loads on the first report only

    cat.audit(catalog_of(request), actor=user, action="download", trial_id=c.trial.id, detail=f"report pdf {c.stage}")
    name = f"{c.patient.id}-{c.trial.session}-{c.trial.id}.pdf"
    return Response(render(c), media_type="application/pdf",
                    headers={"Content-Disposition": f'inline; filename="{name}"'})


@router.get("/trials/{trial_id}/parameters", summary="Every parameter: left, right, mean, SD, CV, symmetry, norms")
def parameters(trial_id: str, request: Request, user: str = Depends(require_user)) -> dict:
    """The report's numbers as JSON (units in ``unit``; ``null`` where not measured)."""
    c = _content(request, trial_id)
    rows, doubt = [], set(c.consistency.get("parameters_in_doubt") or ())
    for r in c.rows:
        p = PARAMETERS[r.name]
        band = r.norm.band() if r.norm is not None else None
        rows.append({"name": r.name, "label": p.label, "unit": p.unit, "decimals": p.decimals, "help": p.help,
                     "left": _num(r.left, 4), "right": _num(r.right, 4), "mean": _num(r.mean, 4),
                     "sd": _num(r.sd, 4), "cv_pct": _num(r.cv_pct, 2), "symmetry_index_pct": _num(r.si_pct, 2),
                     "n": r.n, "normal_range": [round(band[0], 4), round(band[1], 4)] if band else None,
                     "z": _num(r.z, 2), "percentile": _num(r.percentile, 1),
                     "norm_source": r.norm.source if r.norm is not None else None,
                     "previous": _num(c.previous.values.get(r.name, math.nan), 4) if c.previous else None,
                     "in_doubt": r.name in doubt, "unstable": r.name in c.unstable, "shown": _shown(r, c)})
    return {"trial_id": c.trial.id, "subject_id": c.patient.id, "session": c.trial.session,
            "started_at": c.trial.started_at, "stage": c.stage, "method": c.method, "age": c.age,
            "sex": c.patient.sex, "parameters": rows, "flags": list(c.flags), "withheld": list(c.withheld),
            "warnings": list(c.warnings),
            "data_problems": list(c.data_problems), "norm_summary": c.norm_summary, "consistency": c.consistency,
            "gait_speed_reference": c.speed_reference,
            "analysis_notes": list(c.analysis_notes), "num_steps": c.num_steps, "num_passes": c.num_passes, "voided": c.details.voided, "void_reason": c.details.void_reason,
            "details": {k: getattr(c.details, k) for k in DETAIL_FIELDS},
            "previous_trial": c.previous.trial.id if c.previous else None,
            "footprints": [{"side": f.side, "along_mm": round(f.along_mm, 1), "across_mm": round(f.across_mm, 1)}
                           for f in c.footprints],
            "norm_sources": list(c.norm_citations)}


@router.get("/trials/{trial_id}/figures", summary="Data of the page's figures: heel heights over time and the events")
def figures(trial_id: str, request: Request, user: str = Depends(require_user)) -> dict:
    """Both heels' height (mm) over time (s), at most 1500 samples, with each foot's heel strikes and
    toe offs (s); the footprints are in ``/parameters``."""
    db, data_dir = catalog_of(request), request.app.state.settings.data_dir
    trial_id = checked_trial_id(trial_id)
    result = cat.get_result(db, trial_id)
    if result is None:
        raise HTTPException(status_code=404, detail=f"trial {trial_id} has no results yet")
    try:
        traces = heel_traces(trial_files(data_dir, trial_id).stage_file(result.stage, "trajectory_npz"),
                             stored_gait(data_dir, trial_id, result.stage))
    except FileNotFoundError as exc:
        raise HTTPException(status_code=404, detail=f"trial {trial_id}: {exc}") from None
    return {"trial_id": trial_id, "stage": result.stage, **traces}
