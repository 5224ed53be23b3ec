import numpy as np
import pytest
from gaitcap.acquisition.readers import load_rig
from gaitcap.services.cli import app
from gaitcap.simulator import WalkParams, make_trial
from gaitcap.simulator.files import load_trial_files, save_trial
from typer.testing import CliRunner

GT_KEYS = {
    "points_mm", "times_s", "joint_names", "skeleton", "heel_strike_s_left", "heel_strike_s_right",
    "toe_off_s_left", "toe_off_s_right", "step_foot", "step_heel_strike_s", "step_heel_mm", "step_toe_mm",
    "step_length_mm", "stride_length_mm", "step_width_mm", "step_pass", "params_json",
}


def test_cli_writes_the_documented_files(tmp_path):
    out = tmp_path / "sim"
    res = CliRunner().invoke(app, ["simulate", "--preset", "clean", "--seconds", "8", "--cameras", "4",
                                   "--people", "2", "--seed", "3", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "step length" in res.output and "cadence" in res.output and "steps" in res.output
    rig = load_rig(out / "calibration.toml")
    assert rig.names == ["cam01", "cam02", "cam03", "cam04"]
    with np.load(out / "keypoints.npz") as kp:
        assert {"keypoints", "cameras", "times_s", "skeleton", "multi_keypoints", "multi_identity"} <= set(kp.files)
        t = kp["times_s"].shape[0]
        assert t == 240 and kp["keypoints"].shape == (4, t, 26, 3)
        assert kp["multi_keypoints"].shape == (4, t, 2, 26, 3) and kp["multi_identity"].shape == (4, t, 2)
        assert list(kp["cameras"]) == rig.names and str(kp["skeleton"]) == "halpe26"
    with np.load(out / "ground_truth.npz") as gt:
        assert GT_KEYS | {"all_points_mm"} <= set(gt.files)
        s = gt["step_length_mm"].shape[0]
        assert gt["points_mm"].shape == (t, 26, 3) and gt["all_points_mm"].shape == (2, t, 26, 3)
        assert gt["step_heel_mm"].shape == (s, 3) and gt["step_toe_mm"].shape == (s, 3)
        assert gt["step_foot"].shape == (s,) and set(gt["step_foot"]) <= {"left", "right"}
        assert gt["step_pass"].dtype.kind == "i" and len(gt["joint_names"]) == 26
        assert WalkParams.from_json(str(gt["params_json"])) == WalkParams()


def test_save_and_load_round_trip(tmp_path):
    tr = make_trial("paper", seconds=6.0, cameras=3, seed=2)
    save_trial(tr, tmp_path)
    back = load_trial_files(tmp_path)
    assert np.array_equal(back.detections.one_person, tr.detections.one_person, equal_nan=True)
    assert back.rig.names == tr.rig.names
    for a, b in zip(back.rig, tr.rig, strict=True):
        assert np.allclose(a.matrix_px, b.matrix_px) and np.allclose(a.tvec_mm, b.tvec_mm, atol=1e-9)
    assert np.array_equal(back.ground_truth["points_mm"], tr.points_mm)
    assert back.params == tr.params
    with np.load(tmp_path / "keypoints.npz") as kp:
        assert "multi_keypoints" not in kp.files


def test_cli_json_summary(tmp_path):
    res = CliRunner().invoke(app, ["simulate", "--seconds", "6", "--cameras", "2", "--out", str(tmp_path), "--json"])
    assert res.exit_code == 0, res.output
    assert '"cadence_spm"' in res.output


@pytest.mark.parametrize(
    "args, message",
    [
        (["--preset", "fancy"], "unknown preset 'fancy'"),
        (["--seconds", "1"], "seconds must be >= 4"),
        (["--cameras", "1"], "cameras must be an integer >= 2"),
        (["--people", "5"], "people must be 1, 2 or 3"),
    ],
)
def test_cli_bad_arguments(tmp_path, args, message):
    res = CliRunner().invoke(app, ["simulate", "--out", str(tmp_path / "x"), *args])
    assert res.exit_code == 2
    assert message in res.output
    assert not (tmp_path / "x").exists()
