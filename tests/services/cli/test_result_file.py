"""``gaitcap reconstruct`` + ``gaitcap gait`` give the worker's gait (``gaitcap process``'s gait.json): one
result file (``outputs.write_npz``) carrying the dense samples of the fit that the events are found on."""

import json
import math

import numpy as np
import pytest
from gaitcap.acquisition.writers import save_detections_npz, save_rig
from gaitcap.services.cli import app
from gaitcap.simulator import make_trial
from typer.testing import CliRunner

# Events to 1 us and lengths to 1 um: the file's float64 dense samples rebuild the worker's spline exactly
# (measured: identical). Gait from the frames alone differed by up to 11 ms in heel strikes, 26 ms in toe-offs,
# 2.7 mm in step length and 0.1 m/s in gait speed on this recording (bench/result_file.py, docs/offline.md).
ATOL = 1e-6


def _numbers(tree, prefix=""):
    """Flatten a JSON tree into {path: value} for the numbers and words in it."""
    if isinstance(tree, dict):
        return {k: v for key, sub in tree.items() for k, v in _numbers(sub, f"{prefix}/{key}").items()}
    if isinstance(tree, list):
        return {k: v for i, sub in enumerate(tree) for k, v in _numbers(sub, f"{prefix}/{i}").items()}
    return {prefix: tree}


def _assert_same(worker: dict, cli: dict) -> None:
    a, b = _numbers(worker), _numbers(cli)
    assert a.keys() == b.keys()
    for key, x in a.items():
        y = b[key]
        if isinstance(x, float) and isinstance(y, float) and not (math.isnan(x) and math.isnan(y)):
            assert abs(x - y) <= ATOL, f"{key}: worker {x}, reconstruct + gait {y}"
        elif not isinstance(x, float):
            assert x == y, f"{key}: worker {x!r}, reconstruct + gait {y!r}"


def test_reconstruct_then_gait_gives_the_workers_gait(tmp_path):
    trial = make_trial(preset="paper", seconds=6.0, cameras=4, seed=3)
    save_detections_npz(trial.detections, tmp_path / "kp.npz")
    save_rig(trial.rig, tmp_path / "calib.json")
    inputs = ["--calibration", str(tmp_path / "calib.json")]
    runner = CliRunner()
    res = runner.invoke(app, ["process", str(tmp_path / "kp.npz"), *inputs, "--out", str(tmp_path / "proc"),
                              "--no-kinematics"])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["reconstruct", "--keypoints", str(tmp_path / "kp.npz"), *inputs,
                              "--out", str(tmp_path / "rec.npz")])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["gait", str(tmp_path / "rec.npz"), "--json"])
    assert res.exit_code == 0, res.output
    cli = json.loads(res.stdout.strip().splitlines()[-1])
    worker = json.loads((tmp_path / "proc" / "refined" / "gait.json").read_text())
    assert len(worker["steps"]) >= 3
    _assert_same({k: worker[k] for k in ("steps", "summary", "contacts")},
                 {k: cli[k] for k in ("steps", "summary", "contacts")})
    with np.load(tmp_path / "rec.npz") as rec, np.load(tmp_path / "proc" / "refined" / "trajectory.npz") as work:
        assert set(rec.files) == set(work.files) >= {"dense_times_s", "dense_points_mm", "method", "camera_names"}
        assert list(rec["camera_names"]) == list(trial.rig.names)
        assert rec["dense_points_mm"].shape == (4 * (len(rec["times_s"]) - 1) + 1, *rec["points_mm"].shape[1:])


def test_dense_samples_that_do_not_fit_are_named(tmp_path):
    from gaitcap.services.processing.outputs import read_npz

    npz = tmp_path / "bad.npz"
    np.savez(npz, points_mm=np.zeros((10, 3, 3)), times_s=np.arange(10) / 30, joint_names=np.array(["a", "b", "c"]),
             dense_times_s=np.linspace(0, 0.3, 37), dense_points_mm=np.zeros((37, 2, 3)))
    with pytest.raises(ValueError, match=r"dense_points_mm \(37, 2, 3\).*3 joints"):
        read_npz(npz)
