"""The calibration job on a board recording written like the recorder's: a passing run is stored and
becomes the active calibration; a camera that never sees the board fails the run, named, not activated."""

import numpy as np
import pytest
from gaitcap.acquisition.board import BoardConfig, make_board
from gaitcap.acquisition.synthetic.board import (
    BoardMotion,
    board_trajectory,
    render_board_images,
    scaled_rig,
    write_board_mcap,
)
from gaitcap.acquisition.synthetic.room import build_rig
from gaitcap.reconstruction.calibration.geometry import rotation_angle_deg
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import calibration_runs as runs
from gaitcap.services.processing.calibration_job import run_calibration

SCALE = 0.3


@pytest.fixture(scope="module")
def images():
    rig = build_rig(10, seed=0).subset(["cam01", "cam02"])
    board = make_board(BoardConfig.checkerboard())
    rot, tvec = board_trajectory(board.geometry, BoardMotion(n_frames=32, floor_frames=3, seed=3), rig)
    return render_board_images(rig, board, rot, tvec, scale=SCALE), scaled_rig(rig, SCALE)


def _run(tmp_path, frames):
    db = cat.open_catalog(tmp_path / "catalog.sqlite")
    mcap = write_board_mcap(tmp_path / "board.mcap", frames)
    run = runs.start_calibration_run(db, recording_path_for=lambda _id: mcap, started_by="alice")
    runs.update_calibration_run(db, run.id, state=runs.CALIBRATING)
    run_calibration(db, run.id, expected_images=64)
    return db, runs.get_calibration_run(db, run.id)


def test_a_good_recording_becomes_the_active_calibration(images, tmp_path):
    from gaitcap.reconstruction.calibration_io import load_rig

    frames, truth = images
    db, run = _run(tmp_path, frames)
    assert run.state == "done", run.error
    assert cat.latest_calibration(db)[0] == run.id == run.calibration_id
    assert [c["name"] for c in run.report["cameras"]] == ["cam01", "cam02"]
    (tmp_path / "got.toml").write_text(runs.calibration_run_toml(db, run.id))
    got = load_rig(tmp_path / "got.toml")
    for true, cam in zip(truth, got, strict=True):  # the CLI test's bounds for a short low-resolution clip
        assert np.linalg.norm(true.center_mm - cam.center_mm) < 100, true.name
        assert rotation_angle_deg(true.rotation, cam.rotation) < 1.0, true.name
    assert runs.current_board_recording(db) is None


def test_a_camera_without_the_board_fails_the_run_naming_it(images, tmp_path):
    frames, _ = images
    frames = {**frames, "cam03": np.full_like(frames["cam01"], 110)}
    db, run = _run(tmp_path, frames)
    assert run.state == "failed" and "cam03" in run.error
    assert cat.latest_calibration(db) is None  # never activated


def test_one_recording_at_a_time(tmp_path):
    db = cat.open_catalog(tmp_path / "catalog.sqlite")
    run = runs.start_calibration_run(db, recording_path_for=lambda i: tmp_path / f"{i}.mcap")
    with pytest.raises(runs.CalibrationBusy, match=run.id):
        runs.start_calibration_run(db, recording_path_for=lambda i: tmp_path / f"{i}.mcap")
    runs.update_calibration_run(db, run.id, state=runs.FAILED, error="stopped")
    trial = cat.start_trial(db, subject_id="P1", session="s1")
    with pytest.raises(runs.CalibrationBusy, match=trial.id):
        runs.start_calibration_run(db, recording_path_for=lambda i: tmp_path / f"{i}.mcap")


def test_a_killed_job_fails_its_run(images, tmp_path):
    """SIGKILL (what the OOM killer sends) mid-detection: the run must not stay 'calibrating'."""
    import os
    import signal
    import time

    from gaitcap.services.processing.calibration_job import launch

    frames, _ = images
    long = {cam: np.concatenate([f] * 20) for cam, f in frames.items()}  # about a minute of detection
    db = cat.open_catalog(tmp_path / "catalog.sqlite")
    mcap = write_board_mcap(tmp_path / "board.mcap", long)
    run = runs.start_calibration_run(db, recording_path_for=lambda _id: mcap)
    runs.update_calibration_run(db, run.id, state=runs.CALIBRATING)
    proc = launch(str(tmp_path / "catalog.sqlite"), run.id, expected_images=2 * len(long["cam01"]))
    deadline = time.monotonic() + 60
    while runs.get_calibration_run(db, run.id).stage.startswith("finding") is False:
        assert time.monotonic() < deadline, "the job never started finding the board"
        time.sleep(0.2)
    os.kill(proc.pid, signal.SIGKILL)
    while runs.get_calibration_run(db, run.id).state == runs.CALIBRATING:
        assert time.monotonic() < deadline, "the run stayed calibrating after its job was killed"
        time.sleep(0.2)
    failed = runs.get_calibration_run(db, run.id)
    assert failed.state == "failed" and "killed by signal 9" in failed.error
    assert cat.latest_calibration(db) is None
