"""Calibrate from a stopped board recording, as a process of its own (the API starts it at Stop).

``python -m gaitcap.services.processing.calibration_job --catalog URL --id RUN_ID [--frames N]``: finds the board in the
run's MCAP, calibrates every camera, stores the calibration and its quality report in the catalog
(:mod:`gaitcap.services.catalog.calibration_runs`); progress goes to the run's ``stage`` / ``progress``. A
recording the maths refuses (a camera that never saw the board, ...) fails naming the reason.
"""

from __future__ import annotations

import argparse
import logging
import subprocess
import sys
import time

from gaitcap.services.catalog import open_catalog
from gaitcap.services.catalog.calibration_runs import (
    CALIBRATING,
    FAILED,
    finish_calibration_run,
    get_calibration_run,
    update_calibration_run,
)

log = logging.getLogger(__name__)


def _toml_text(rig, rms_px: float) -> str:
    from gaitcap.reconstruction.calibration_io import rig_to_toml_text

    return rig_to_toml_text(rig, metadata={"error": rms_px})


def run_calibration(catalog, run_id: str, *, expected_images: int | None = None, board=None) -> None:
    """Calibrate run ``run_id`` (state ``calibrating``) and store the outcome (never raises ValueError)."""
    from gaitcap.acquisition.board import BoardConfig
    from gaitcap.acquisition.board_recording import find_board_views
    from gaitcap.reconstruction.calibration import CalibrationConfig, calibrate_from_observations

    run = get_calibration_run(catalog, run_id)
    last = [0.0]

    def progress(done: int, _total) -> None:
        if time.monotonic() - last[0] > 0.5:
            last[0] = time.monotonic()
            frac = min(done / expected_images, 1.0) if expected_images else 0.0
            update_calibration_run(catalog, run_id, stage=f"finding the board ({done} images)", progress=0.8 * frac)

    try:
        update_calibration_run(catalog, run_id, stage="finding the board", progress=0.0)
        found = find_board_views(run.recording_path, board=board or BoardConfig(), progress=progress)
        config = CalibrationConfig()
        found.check(config.intrinsics.min_views)  # per camera: what was found and what to change
        update_calibration_run(catalog, run_id, stage="calibrating the cameras", progress=0.8)
        result = calibrate_from_observations(found.observations, config=config)
    except ValueError as exc:
        log.warning("calibration %s failed: %s", run_id, exc)
        update_calibration_run(catalog, run_id, state=FAILED, stage="", progress=1.0, error=str(exc))
        return
    report = result.report
    problems = "; ".join(f"{q.name}: {', '.join(q.problems)}" for q in report.cameras if not q.ok)
    finish_calibration_run(catalog, run_id, toml=_toml_text(result.rig, report.reprojection_rms_px),
                           report=report.to_dict(), failed=list(report.failed_cameras), problems=problems)
    log.info("calibration %s: RMS %.3f px, failed cameras %s", run_id, report.reprojection_rms_px,
             list(report.failed_cameras))


def launch(catalog_url: str, run_id: str, *, expected_images: int | None = None) -> subprocess.Popen:
    """Start the job as a child process, reaped by a daemon thread that fails the run when the process
    dies without finishing it (killed, out of memory)."""
    import threading

    argv = [sys.executable, "-m", "gaitcap.services.processing.calibration_job", "--catalog", catalog_url, "--id", run_id]
    if expected_images:
        argv += ["--frames", str(int(expected_images))]
    proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL)
    threading.Thread(target=reap, args=(proc, catalog_url, run_id), name=f"calibration-{run_id}",
                     daemon=True).start()
    return proc


def reap(proc: subprocess.Popen, catalog_url: str, run_id: str) -> None:
    """Wait for the job; a run it left ``calibrating`` becomes ``failed``, naming how the job ended."""
    code = proc.wait()
    catalog = open_catalog(catalog_url)
    try:
        if get_calibration_run(catalog, run_id).state != CALIBRATING:
            return
        how = f"was killed by signal {-code}" if code < 0 else f"exited with code {code}"
        log.warning("calibration job %s %s", run_id, how)
        update_calibration_run(catalog, run_id, expect=CALIBRATING, state=FAILED, stage="", progress=1.0,
                               error=f"the calibration job {how} before finishing; press Calibrate to record again")
    except ValueError:  # it finished in the meantime
        pass
    finally:
        catalog.close()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--catalog", required=True, help="Catalog path or URL")
    parser.add_argument("--id", required=True, help="Calibration run id")
    parser.add_argument("--frames", type=int, default=None, help="Images in the recording (for progress)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s calibration %(levelname)s %(message)s")
    catalog = open_catalog(args.catalog)
    try:
        run_calibration(catalog, args.id, expected_images=args.frames)
    except Exception as exc:  # anything unexpected: the run must not stay "calibrating" for ever
        log.exception("calibration %s crashed", args.id)
        update_calibration_run(catalog, args.id, state=FAILED, stage="", progress=1.0,
                               error=f"calibration crashed: {type(exc).__name__}: {exc}")
        return 1
    finally:
        catalog.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())

__all__ = ["CALIBRATING", "launch", "main", "reap", "run_calibration"]
