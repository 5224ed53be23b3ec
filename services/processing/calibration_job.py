"""Calibrate from a stopped board recording: the ``calibrate`` job a worker takes from the job table.

Finds the board in the recording's MCAP, calibrates every camera and stores the calibration with its
quality report in the catalog (:mod:`gaitcap.services.catalog.calibrations`); progress goes to the
calibration's ``stage`` / ``progress``. Too few board views: the error names, per camera, what was found
and the likely cause (:mod:`gaitcap.acquisition.boards.diagnosis`); any other recording the maths refuses
(a camera that failed the quality checks, ...) fails naming the reason. The board searched for is the
one recorded on the calibration when its recording started (the clinic's board file, or the board given
to Start); a record without one uses the default board. The report and every failure name the board used.
A worker that dies mid-way stops renewing the job's lease and another worker calibrates again from the start.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

from gaitcap.services.catalog import Catalog
from gaitcap.services.catalog.calibrations import (
    CALIBRATING,
    FAILED,
    finish_calibration,
    get_calibration,
    refuse_calibration,
    update_calibration,
)
from gaitcap.services.processing.boards import board_used

log = logging.getLogger(__name__)


def _toml_text(rig, rms_px: float) -> str:
    from gaitcap.reconstruction.calibration_io import rig_to_toml_text

    return rig_to_toml_text(rig, metadata={"error": rms_px})


def _progress(catalog: Catalog, cal_id: str, expected_images: int | None, check: Callable[[], None]):
    last = [0.0]

    def progress(done: int, _total) -> None:
        check()
        if time.monotonic() - last[0] > 0.5:
            last[0] = time.monotonic()
            frac = min(done / expected_images, 1.0) if expected_images else 0.0
            update_calibration(catalog, cal_id, stage=f"finding the board ({done} images)", progress=0.8 * frac)

    return progress


def run_calibration(catalog: Catalog, cal_id: str, *, board=None, check: Callable[[], None] = lambda: None) -> None:
    """Calibrate ``cal_id`` (state ``calibrating``; another state: nothing to do) and store the outcome.

    ``board``: a BoardConfig overriding the calibration's recorded board (:func:`board_used`). A recording
    the maths refuses fails the calibration naming why and the board used (never raises ValueError);
    ``check()`` is called as images are read (the worker's lease check: raises when the job was lost)."""
    from gaitcap.acquisition.boards.recording import find_board_views
    from gaitcap.reconstruction.calibration import CalibrationConfig, calibrate_from_observations

    cal = get_calibration(catalog, cal_id)
    if cal.state != CALIBRATING:
        log.info("calibration %s is %s; nothing to do", cal_id, cal.state)
        return
    words = "none: the board recorded on the calibration is not a board"  # until board_used() read it
    found, config = None, CalibrationConfig()
    try:
        board, words = (board, board.describe()) if board is not None else board_used(cal)
        update_calibration(catalog, cal_id, stage="finding the board", progress=0.0)
        found = find_board_views(cal.recording_path, board=board,
                                 progress=_progress(catalog, cal_id, cal.frames, check))
        found.check(config.intrinsics.min_views)  # per camera: what was found and what to change
        check()
        update_calibration(catalog, cal_id, stage="calibrating the cameras", progress=0.8)
        result = calibrate_from_observations(found.observations, config=config, views_removed=found.views_removed)
    except ValueError as exc:
        log.warning("calibration %s failed (board used: %s): %s", cal_id, words, exc)
        seen = detections_report(found, config.intrinsics.min_views) if found is not None else []
        refuse_calibration(catalog, cal_id, error=f"{without_table(str(exc))} (board used: {words})",
                           report={"board_used": words, "detections": seen})
        return
    check()
    report = result.report
    problems = "; ".join(f"{q.name}: {', '.join(q.problems)}" for q in report.cameras if not q.ok)
    finish_calibration(catalog, cal_id, toml=_toml_text(result.rig, report.reprojection_rms_px),
                       report=report.to_dict() | {"board_used": words}, failed=list(report.failed_cameras),
                       problems=problems)
    log.info("calibration %s: RMS %.3f px, failed cameras %s", cal_id, report.reprojection_rms_px,
             list(report.failed_cameras))


def without_table(message: str) -> str:
    """``message`` without the detection table appended to it (the page shows it per camera)."""
    from gaitcap.acquisition.boards.diagnosis import HEADER

    return message.split("\n\n" + HEADER)[0].strip()


def detections_report(found, min_views: int) -> list[dict]:
    """Per camera of a board recording: what the board detector found, for a failed calibration's
    report (``seen``: the board was found in at least one frame; ``usable`` views and distinct board
    ``positions`` against ``needed``; ``advice``: what to change, empty when the camera had enough views)."""
    from gaitcap.acquisition.boards.diagnosis import positions_advice

    positions = found.positions()
    return [{"name": c.name, "frames": c.frames, "with_board": c.with_board, "usable": c.usable(),
             "positions": int(n), "needed": min_views, "seen": c.with_board > 0,
             "advice": c.advice(found.board, min_views) or positions_advice(c, int(n), min_views)}
            for c, n in zip(found.cameras, positions, strict=True)]


def fail_calibration(catalog: Catalog, cal_id: str, exc: Exception) -> None:
    """The job crashed (not a refusal of the maths): the calibration must not stay ``calibrating``."""
    try:
        update_calibration(catalog, cal_id, expect=CALIBRATING, state=FAILED, stage="", progress=1.0,
                           error=f"calibration crashed: {type(exc).__name__}: {exc}")
    except ValueError:  # finished in the meantime
        log.warning("calibration %s could not be marked failed", cal_id)


__all__ = ["detections_report", "fail_calibration", "run_calibration", "without_table"]
