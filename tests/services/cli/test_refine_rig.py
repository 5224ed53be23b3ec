"""``gaitcap refine-rig``: a synthetic trial on disk, its calibration made stale by turning one camera; the
command names the moved camera (--check) and writes a refined calibration that brings it back."""

from __future__ import annotations

import json

from gaitcap.acquisition.readers import load_rig
from gaitcap.acquisition.writers import save_rig
from gaitcap.reconstruction.calibration.geometry import rotation_angle_deg
from gaitcap.reconstruction.camera import Rig
from gaitcap.services.cli import app
from gaitcap.simulator import make_trial, save_trial
from gaitcap.simulator.rig_faults import with_camera_moved
from typer.testing import CliRunner

MOVED = "cam02"


def _stale(rig: Rig) -> Rig:
    return with_camera_moved(rig, MOVED, rotation_deg=2.0)


def test_refine_rig_checks_and_refines(tmp_path):
    trial = make_trial(preset="paper", seconds=8.0, cameras=5, seed=4)
    files = save_trial(trial, tmp_path / "trial")
    save_rig(_stale(trial.rig), tmp_path / "stale.toml")
    runner = CliRunner()
    keypoints = str(files["keypoints"])
    res = runner.invoke(app, ["refine-rig", keypoints, "--calibration", str(tmp_path / "stale.toml"), "--check"])
    assert res.exit_code == 0, res.output
    assert f"cameras moved: {MOVED}" in res.output
    res = runner.invoke(app, ["refine-rig", keypoints, "--calibration", str(tmp_path / "stale.toml"),
                              "--out", str(tmp_path / "refined.toml"), "--max-frames", "60"])
    assert res.exit_code == 0, res.output
    refined = load_rig(tmp_path / "refined.toml")
    assert rotation_angle_deg(refined[MOVED].rotation, trial.rig[MOVED].rotation) < 0.3
    report = json.loads((tmp_path / "refined.report.json").read_text())
    assert report["change_from_prior"][MOVED]["rotation_deg"] > 1.5
    assert report["median_after_px"] < report["median_before_px"]


def test_refine_rig_needs_an_output(tmp_path):
    res = CliRunner().invoke(app, ["refine-rig", str(tmp_path), "--calibration", str(tmp_path / "c.toml")])
    assert res.exit_code == 2
    assert "--out" in res.output


def test_from_people_alone_takes_one_walk(tmp_path):
    trial = make_trial(preset="paper", seconds=4.0, cameras=4, seed=6)
    files = save_trial(trial, tmp_path / "trial")
    res = CliRunner().invoke(app, ["refine-rig", str(files["keypoints"]), str(files["keypoints"]),
                                   "--calibration", str(files["calibration"]), "--height-mm", "1750",
                                   "--out", str(tmp_path / "people.toml")])
    assert res.exit_code == 2
    assert "one walk" in res.output
