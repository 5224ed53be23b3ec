"""The trial's checks of its own results, run by the one processing path on the first stage's points and
stored in the trial's data-quality block under ``checks`` (each a JSON-ready dict whose ``warnings`` join
the trial's, and whose ``notes`` do not):

- ``one_person``: the reconstruction follows one person seen by every view, not a mix of two
  (:func:`gaitcap.reconstruction.people_check.check_one_person`);
- ``rig``: no camera moved since calibration, judged from the patient's own keypoints
  (:func:`gaitcap.reconstruction.calibration.rig_check.check_rig`).

Each stage's gait parameters are checked against each other apart (:func:`stage_consistency`): a failed
rule is a data problem of that stage, never a clinical finding.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints

log = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class CheckContext:
    """What a trial's checks may compare with besides the trial itself: ``rig_baseline``, the patient's
    keypoints of an earlier trial under the same calibration (the rig check's baseline, see
    :func:`rig_check`), and ``baseline_trial``, that trial's id (named in the check). Without one (no
    earlier trial, or an input outside the clinic) each camera's ``baseline`` reads ``none``."""

    rig_baseline: MultiViewKeypoints | None = None
    baseline_trial: str | None = None


def one_person_check(det: MultiViewKeypoints, rig: Rig, points_mm: np.ndarray,
                     context: CheckContext = CheckContext()) -> dict:
    """``check_one_person`` of the patient's detections (C, T, J, 3) px and points (T, J, 3) mm, with the
    mix as a warning."""
    from gaitcap.reconstruction.people_check import check_one_person

    verdict = check_one_person(det, rig, points_mm)
    return {**verdict.to_dict(), "warnings": [verdict.message] if verdict.mixed else [], "notes": []}


def rig_check(det: MultiViewKeypoints, rig: Rig, points_mm: np.ndarray, context: CheckContext = CheckContext()) -> dict:
    """``check_rig`` of the patient's detections and points: a moved camera is a warning (named, with its
    rotation deg and shift mm and how far the trial lets them be off); a camera that could not be judged,
    or a rig too small to check, a note. With ``context.rig_baseline`` each camera is judged by the change
    since that trial (``baseline_trial`` names it); a baseline that cannot be compared (another camera set
    or keypoint layout) is set aside with a note naming why."""
    from gaitcap.reconstruction.calibration.rig_check import check_rig

    notes, baseline = [], context.rig_baseline
    try:
        try:
            result = check_rig(det, rig, points_mm, baseline=baseline)
        except ValueError as exc:
            if baseline is None:
                raise
            notes.append(f"Rig check: the baseline trial {context.baseline_trial} was set aside ({exc})")
            baseline, result = None, check_rig(det, rig, points_mm)
    except ValueError as exc:  # fewer than 3 cameras: nothing to judge a camera against
        return {"run": False, "flagged": False, "moved": [], "warnings": [], "notes": notes + [str(exc)]}
    moved = set(result.moved)
    warnings = [w for w in result.warnings if any(f"Camera {name} " in w for name in moved)]
    return {**result.to_dict(), "run": True, "warnings": warnings,
            "baseline_trial": context.baseline_trial if baseline is not None else None,
            "notes": notes + [w for w in result.warnings if w not in warnings] + _baseline_note(context, baseline)}


def _baseline_note(context: CheckContext, used: MultiViewKeypoints | None) -> list[str]:
    if used is None:
        return []
    return [f"Rig check: each camera judged by its change since trial {context.baseline_trial}, the first trial "
            "under this calibration whose check found no camera moved."]


def completion_check(report) -> dict:
    """A :class:`~gaitcap.services.processing.completion.CompletionReport` as a check: live and final
    coverage per camera; corrupt images (named, skipped) and recorded frames still without keypoints are
    warnings, what was completed a note."""
    data = report.to_dict()
    warnings = []
    for camera, row in data["cameras"].items():
        if row["corrupt"]:
            warnings.append(f"Camera {camera}: {row['corrupt']} recorded image(s) could not be read and were skipped "
                            f"(frames {', '.join(str(f) for f in row['corrupt_frame_ids'])})")
        if row["missing"] - row["corrupt"] > 0:
            warnings.append(f"Camera {camera}: {row['missing'] - row['corrupt']} recorded frame(s) still have no "
                            f"keypoints after completion with {data['detector']}")
    return {**data, "warnings": warnings, "notes": [_completion_note(data)]}


def _completion_note(data: dict) -> str:
    """What the completion did, in words, with the live pass's coverage where its keypoints were read."""
    frames, by = data["frames"], f"with {data['detector']} in {data['seconds']:.1f} s"
    live = ("" if frames.get("live_pass") is None else
            f" (the live pass had detected {frames['live_pass']}: "
            f"{100 * frames['live_pass'] / max(1, frames['recorded']):.1f} % live coverage)")
    if data["redetected_all"]:
        return f"{frames['completed']} of {frames['recorded']} recorded frames were detected again after Stop {by}{live}"
    return (f"{frames['completed']} of {frames['recorded']} recorded frames had no live keypoints and were detected "
            f"after Stop {by}{live}")


def stage_consistency(report, times_s: np.ndarray) -> dict:
    """The consistency rules on a stage's gait report (``ConsistencyReport.to_dict()``), tolerances from
    the frame period (s, the median step of ``times_s``); {} without a report."""
    from gaitcap.reconstruction.gait.consistency import check_report

    if report is None or len(times_s) < 2:
        return {}
    return check_report(report, frame_period_s=float(np.median(np.diff(times_s)))).to_dict()
