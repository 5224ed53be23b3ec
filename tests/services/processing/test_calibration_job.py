"""The calibration job on a board recording written like the recorder's, taken by a worker from the job
table: a passing recording is stored and becomes the active calibration; a camera that never sees the
board fails it, named with the per-camera diagnosis, not activated; a worker killed mid-calibration
(SIGKILL, a real process) loses its lease and another worker calibrates it."""

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from gaitcap.reconstruction.calibration.geometry import rotation_angle_deg
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import calibrations as cals
from gaitcap.services.processing.worker import Worker, WorkerConfig
from gaitcap.simulator.board import write_board_mcap

from ..conftest import board_images

SCALE = 0.3
WORKER = (sys.executable, "-c", "from gaitcap.services.cli import main; main()", "worker", "--no-bus", "--no-warm-up")


@pytest.fixture(scope="module")
def images():
    return board_images(SCALE)


def _queued(tmp_path, frames) -> tuple[cat.Catalog, str]:
    """A stopped board recording of ``frames`` with its calibrate job queued (what Stop leaves)."""
    db = cat.open_catalog(tmp_path / "catalog.sqlite")
    mcap = write_board_mcap(tmp_path / "board.mcap", frames)
    c = cals.start_board_recording(db, recording_path_for=lambda _id: mcap, started_by="alice")
    cals.queue_calibration(db, c.id, frames=sum(len(f) for f in frames.values()))
    return db, c.id


def _run(tmp_path, frames):
    db, cal_id = _queued(tmp_path, frames)
    worker = Worker(WorkerConfig(catalog_url=db.url, data_dir=tmp_path, refine=False), db=db)
    assert worker.run_once() and not worker.run_once()
    assert [j.state for j in cat.jobs_for_calibration(db, cal_id)] == ["done"]
    return db, cals.get_calibration(db, cal_id)


def test_a_good_recording_becomes_the_active_calibration(images, tmp_path):
    from gaitcap.acquisition.readers import load_rig

    frames, truth = images
    db, run = _run(tmp_path, frames)
    assert run.state == "done", run.error
    assert cat.latest_calibration(db)[0] == run.id and run.kind == "board recording"
    assert [c["name"] for c in run.report["cameras"]] == ["cam01", "cam02"]
    (tmp_path / "got.toml").write_text(cat.calibration_toml(db, run.id))
    got = load_rig(tmp_path / "got.toml")
    for true, cam in zip(truth, got, strict=True):  # the CLI test's bounds for a short low-resolution clip
        assert np.linalg.norm(true.center_mm - cam.center_mm) < 100, true.name
        assert rotation_angle_deg(true.rotation, cam.rotation) < 1.0, true.name
    assert cals.current_board_recording(db) is None


def test_a_camera_without_the_board_fails_naming_it_and_the_cause(images, tmp_path):
    frames, _ = images
    frames = {**frames, "cam03": np.full_like(frames["cam01"], 110)}
    db, run = _run(tmp_path, frames)
    assert run.state == "failed" and "cam03" in run.error, run.error
    assert "camera 'cam03': no frame showed the whole" in run.error  # that camera's diagnosis, not a generic message
    assert "camera 'cam01':" not in run.error and "camera 'cam02':" not in run.error  # the others are not blamed
    assert cat.latest_calibration(db) is None  # never activated


def test_a_board_held_still_fails_naming_the_distinct_positions(images, tmp_path):
    """Every frame shows the board, but always in the same place: enough frames, one position; the error
    says so per camera instead of the maths' generic 'too rarely'."""
    frames, _ = images
    held = {cam: np.repeat(f[5:6], 12, axis=0) for cam, f in frames.items()}  # both cameras see frame 5
    db, run = _run(tmp_path, held)
    assert run.state == "failed", run.error
    for cam in held:
        assert f"camera '{cam}': 12 frames showed the board but only 1 distinct positions remain" in run.error
    found = {d["name"]: d for d in run.report["detections"]}  # the page's table: what to change, per camera
    for cam in held:
        assert found[cam]["positions"] == 1 and found[cam]["usable"] >= found[cam]["needed"], found[cam]
        assert found[cam]["advice"] and "move the board to more places" in found[cam]["advice"][0], found[cam]


def test_one_recording_at_a_time(tmp_path):
    db = cat.open_catalog(tmp_path / "catalog.sqlite")
    run = cals.start_board_recording(db, recording_path_for=lambda i: tmp_path / f"{i}.mcap")
    with pytest.raises(cals.CalibrationBusy, match=run.id):
        cals.start_board_recording(db, recording_path_for=lambda i: tmp_path / f"{i}.mcap")
    cals.update_calibration(db, run.id, state=cals.FAILED, error="stopped")
    trial = cat.start_trial(db, subject_id="P1", session="s1")
    with pytest.raises(cals.CalibrationBusy, match=trial.id):
        cals.start_board_recording(db, recording_path_for=lambda i: tmp_path / f"{i}.mcap")
    with pytest.raises(ValueError, match="recording_path"):
        cals.update_calibration(db, run.id, recording_path="/elsewhere.mcap")


def _worker(db, tmp_path, name: str) -> subprocess.Popen:
    return subprocess.Popen([*WORKER, "--catalog", db.url, "--data-dir", str(tmp_path), "--id", name, "--lease", "2"],
                            stdin=subprocess.DEVNULL)


def _wait(what: str, ok, deadline: float, *procs) -> None:
    while not ok():
        assert time.monotonic() < deadline, what
        assert all(p.poll() is None for p in procs), f"a worker exited while waiting for: {what}"
        time.sleep(0.1)


def test_a_worker_killed_mid_calibration_loses_the_job_to_another(images, tmp_path):
    """SIGKILL (what the OOM killer sends) mid-detection: the lease expires, a second worker takes the
    job again (attempt 2) and the calibration ends done, not stuck ``calibrating``."""
    frames, _ = images
    db, cal_id = _queued(tmp_path, frames)
    first = _worker(db, tmp_path, "w1")
    deadline = time.monotonic() + 60
    try:
        _wait("w1 finding the board", lambda: cals.get_calibration(db, cal_id).stage.startswith("finding the board ("),
              deadline, first)
        os.kill(first.pid, signal.SIGKILL)
        first.wait(10)
        job = cat.jobs_for_calibration(db, cal_id)[0]
        assert (job.state, job.worker_id, job.attempts) == ("running", "w1", 1)
        assert cals.get_calibration(db, cal_id).state == "calibrating"
        second = _worker(db, tmp_path, "w2")
        try:
            _wait("w2 finishing the job", lambda: cat.jobs_for_calibration(db, cal_id)[0].state != "running",
                  deadline + 60, second)
        finally:
            second.send_signal(signal.SIGTERM)
            second.wait(10)
    finally:
        if first.poll() is None:
            first.kill()
    job = cat.jobs_for_calibration(db, cal_id)[0]
    assert (job.state, job.worker_id, job.attempts) == ("done", "w2", 2)
    done = cals.get_calibration(db, cal_id)
    assert done.state == "done" and cat.latest_calibration(db)[0] == cal_id, done.error


def test_a_calibration_whose_recorded_board_is_not_a_board_fails_saying_so(tmp_path):
    from gaitcap.services.processing.calibration_job import run_calibration

    db = cat.open_catalog(tmp_path / "catalog.sqlite")
    c = cals.start_board_recording(db, recording_path_for=lambda _id: tmp_path / "none.mcap", started_by="alice",
                                   board={"kind": "triangle"})
    cals.queue_calibration(db, c.id, frames=10)
    run_calibration(db, c.id)
    got = cals.get_calibration(db, c.id)
    assert got.state == "failed" and f"calibration {c.id} board" in got.error
    assert got.error.endswith("(board used: none: the board recorded on the calibration is not a board)"), got.error
