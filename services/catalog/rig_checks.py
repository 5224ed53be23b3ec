"""The latest trial's rig check (``processing.checks.rig`` of its quality record): what the page shows in
its calibration section "before the next patient" (a camera moved since calibration, named with its
estimated rotation deg and shift mm)."""

from __future__ import annotations

import json

from gaitcap.services.catalog.db import Catalog
from gaitcap.services.catalog.models import Trial, TrialQuality
from gaitcap.services.catalog.states import FINISHED
from sqlalchemy import select

CAMERA_FIELDS = ("name", "judged", "moved", "rotation_deg", "rotation_bound_deg", "shift_mm", "shift_bound_mm",
                 "field_px", "residual_px", "expected_px", "points")


def _summary(trial: Trial, checked_at: float, rig: dict) -> dict:
    return {"trial_id": trial.id, "subject_id": trial.subject_id, "checked_at": checked_at,
            "calibration_id": trial.calibration_id, "flagged": bool(rig.get("flagged")),
            "moved": list(rig.get("moved", [])), "warnings": list(rig.get("warnings", [])),
            "notes": list(rig.get("notes", [])), "baseline_trial": rig.get("baseline_trial"),
            "cameras": [{k: c.get(k) for k in CAMERA_FIELDS} for c in (rig.get("cameras") or {}).values()]}


def _rig_of(quality: TrialQuality) -> dict:
    """The rig check stored in a trial's quality record ({} where none)."""
    return ((json.loads(quality.sections_json).get("processing") or {}).get("checks") or {}).get("rig") or {}


def baseline_trial_ids(catalog: Catalog, calibration_id: str | None, *, excluding: str) -> list[str]:
    """The rig check's baseline candidates under calibration ``calibration_id``, first first: the finished
    trials under it (by Start), other than ``excluding``, whose own rig check ran and found no camera moved;
    [] when there is none (or no calibration is recorded)."""
    if calibration_id is None:
        return []
    with catalog.reading() as s:
        q = (select(Trial, TrialQuality).join(TrialQuality, TrialQuality.trial_id == Trial.id)
             .where(Trial.calibration_id == calibration_id, Trial.id != excluding,
                    Trial.state.in_([x.value for x in FINISHED]))
             .order_by(Trial.started_at, Trial.created_at))
        return [trial.id for trial, quality in s.execute(q)
                if _rig_of(quality).get("run") and not _rig_of(quality).get("flagged")]


def latest_rig_check(catalog: Catalog, *, look_back: int = 20, room: str | None = None) -> dict | None:
    """The rig check of the most recently processed trial that ran one (among the last ``look_back``
    finished trials; of room ``room`` only where given, '' the default room), or None: {trial_id, subject_id, checked_at (UNIX s), calibration_id, flagged, moved,
    warnings, notes, baseline_trial (the trial it was judged against, or None), cameras: [{name, judged, moved, rotation_deg, rotation_bound_deg (deg about the camera's x,
    y and optical axis; absent for checks stored before the bounds), shift_mm, shift_bound_mm, field_px (px),
    residual_px, expected_px, points}]}."""
    with catalog.reading() as s:
        q = (select(Trial, TrialQuality).join(TrialQuality, TrialQuality.trial_id == Trial.id)
             .where(Trial.state.in_([x.value for x in FINISHED])).order_by(TrialQuality.updated_at.desc())
             .limit(look_back))
        if room is not None:
            q = q.where(Trial.room == room)
        for trial, quality in s.execute(q):
            rig = _rig_of(quality)
            if rig.get("run"):
                return _summary(trial, quality.updated_at, rig)
    return None
