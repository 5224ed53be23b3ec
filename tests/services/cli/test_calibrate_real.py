"""``gaitcap calibrate`` on a real session: caliscope's 4 webcams and inverted two-sided ChArUco board
(its corner detections; installed by deploy/bootstrap.sh), compared with caliscope's calibration."""

import json
import re

import numpy as np
import pytest
from gaitcap.acquisition.installed import share_path
from gaitcap.acquisition.readers import load_rig
from gaitcap.services.cli import app
from typer.testing import CliRunner

SESSION = share_path("testdata", "calibration", "caliscope-4cam")
pytestmark = pytest.mark.skipif(not (SESSION / "camera_array.toml").exists(),
                                reason=f"caliscope session not installed in {SESSION} (run deploy/bootstrap.sh)")


def test_with_caliscopes_intrinsics_the_rig_matches_and_is_written(tmp_path):
    out = tmp_path / "calib.toml"
    result = CliRunner().invoke(app, ["calibrate", str(SESSION), "--out", str(out), "--distortion", "k1k2p1p2k3",
                                      "--intrinsics", str(SESSION / "camera_array.toml"),
                                      "--compare", str(SESSION / "camera_array.toml"), "--folds", "3"])
    assert result.exit_code == 0, result.output
    assert "board charuco 4 x 5 squares of 54 mm, markers 40.5 mm DICT_4X4_1000, inverted" in result.output
    m = re.search(r"similarity alignment \(scale ([\d.]+)\): centres max ([\d.]+) mm, rotations max ([\d.]+) deg",
                  result.output)
    assert m and abs(float(m[1]) - 1) < 0.01 and float(m[2]) < 3.0 and float(m[3]) < 0.4, result.output
    assert load_rig(out).names == ["cam_0", "cam_1", "cam_2", "cam_3"]
    # the held-out error: our poses fitted on 2 of 3 folds in time, judged on the third, and caliscope's
    # calibration (--compare) judged on the same frame sets, in the table and in the report
    assert "held-out error (3 folds in time, 50 frame sets judged" in result.output, result.output
    report = json.loads((tmp_path / "calib.report.json").read_text())
    own, theirs = report["held_out"]["own"], report["held_out"]["reference"]
    assert own["frame_sets"] == theirs["frame_sets"] == 50 and own["fold_errors"] == []
    for mine, ref in zip(own["cameras"], theirs["cameras"], strict=True):
        assert mine["views_held_out"] == ref["views_held_out"] and mine["views_judged"] > 0.9 * mine["views_held_out"]
        row = re.search(rf"^{mine['name']} +(\d+) +([\d.]+) +([\d.]+) +([\d.]+)  \| +([\d.]+)", result.output, re.M)
        assert row and abs(float(row[2]) - mine["rms_px"]) < 1e-3 and abs(float(row[5]) - ref["rms_px"]) < 1e-3, row
        assert mine["rms_px"] < 1.6 and ref["rms_px"] < 1.6  # measured: ours 0.6-1.2 px, caliscope's 0.56-1.15 px
    assert abs(own["board"]["square_mm"] - 54.0) < 0.5 and own["problems"] == theirs["problems"] == []
    assert report["board_check"]["described_square_mm"] == 54.0 and report["board_problems"] == []


def test_a_small_board_is_calibrated_holding_what_it_cannot_determine(tmp_path):
    out = tmp_path / "calib.toml"
    result = CliRunner().invoke(app, ["calibrate", str(SESSION), "--out", str(out), "--folds", "0", "--motion"])
    assert result.exit_code == 0, result.output
    assert "note: principal point held at the image centre: the board covered 10 % of the image (< 30 %)" \
        in result.output
    assert out.exists() and not (tmp_path / "calib.refused.toml").exists()
    # --motion: the webcams' time offsets from the board's motion, after the root camera's, each with its
    # standard error, printed and in the report
    motion = json.loads((tmp_path / "calib.report.json").read_text())["motion"]
    root = motion["cameras"].index(motion["root"])
    assert motion["offsets_ms"][root] == 0.0 and all(np.isfinite(motion["offsets_ms"]))
    assert all(0 < se < 5 for c, se in enumerate(motion["offsets_se_ms"]) if c != root), motion
    assert f"the board's motion: time offsets from the board's motion, after {motion['root']}: " in result.output


def test_a_calibration_failing_its_checks_is_refused(tmp_path):
    out = tmp_path / "calib.toml"
    result = CliRunner().invoke(app, ["calibrate", str(SESSION), "--out", str(out), "--strict-intrinsics",
                                      "--folds", "0"])
    assert result.exit_code == 1
    assert "calibration refused for use" in result.output and "board covered 10 % of the image" in result.output
    assert not out.exists() and (tmp_path / "calib.refused.toml").exists() and (tmp_path / "calib.report.json").exists()


ELEVEN = share_path("testdata", "calibration", "caliscope-11cam")


@pytest.mark.skipif(not (ELEVEN / "camera_array.toml").exists(), reason=f"caliscope's 11-camera session not installed in {ELEVEN}")
def test_every_nth_frame_set_of_a_session_from_the_command_line(tmp_path):
    """caliscope's 11 cameras at 1080p, every 20th frame set (as caliscope's own tests thin it) with its
    intrinsics: the rig agrees with caliscope's bundle-adjusted one (measured: 0.2-1.3 mm, <= 0.07 deg)."""
    out, cal = tmp_path / "calib.toml", str(ELEVEN / "camera_array.toml")
    result = CliRunner().invoke(app, ["calibrate", str(ELEVEN), "--out", str(out), "--every", "20",
                                      "--intrinsics", cal, "--compare", cal, "--folds", "0"])
    assert result.exit_code == 0, result.output
    assert "caliscope session (every 20th frame set): views cam_1 " in result.output
    m = re.search(r"centres max ([\d.]+) mm, rotations max ([\d.]+) deg", result.output)
    assert m and float(m[1]) < 3.0 and float(m[2]) < 0.2, result.output
    assert len(load_rig(out).names) == 11
    refused = CliRunner().invoke(app, ["calibrate", str(ELEVEN), "--out", str(out), "--max-frames", "50"])
    assert refused.exit_code != 0 and "--max-frames: a caliscope session holds corner detections" in refused.output


def test_choosing_intrinsics_that_are_given_is_a_usage_error(tmp_path):
    cal = str(SESSION / "camera_array.toml")
    result = CliRunner().invoke(app, ["calibrate", str(SESSION), "--out", str(tmp_path / "c.toml"), "--intrinsics", cal,
                                      "--choose-intrinsics"])
    assert result.exit_code == 2
    assert "--choose-intrinsics: the intrinsics are given (--intrinsics); nothing to choose" in result.output
    assert not (tmp_path / "c.toml").exists()


def test_the_intrinsics_choice_prints_the_rig_figures_and_a_fallback():
    from gaitcap.reconstruction.calibration.model_choice import IntrinsicsChoice
    from gaitcap.services.cli.calibrate import _choice

    fallback = ("each camera's own choice together held out 1.200 px over the rig, the best single candidate "
                "(k1, principal point free) 1.050 px: it is taken for every camera")
    choice = IntrinsicsChoice(("k1, principal point held", "k1, principal point free"),
                              {"cam_0": (1.1, 1.0), "cam_1": (1.0, 1.1)},
                              {"cam_0": "k1, principal point free", "cam_1": "k1, principal point free"},
                              {}, {}, 3, 12.0, "", (1.10, 1.05), 1.05, fallback)
    text = _choice(choice).splitlines()
    assert "rig         1.100  1.050  -> 1.050 with the intrinsics chosen" in text and fallback in text


def test_caliscope_per_fold_needs_its_scripting_api_or_given_intrinsics(tmp_path):
    from gaitcap.acquisition.importers.caliscope import caliscope_available

    out = tmp_path / "c.toml"
    result = CliRunner().invoke(app, ["calibrate", str(SESSION), "--out", str(out), "--caliscope-folds", "both"])
    assert result.exit_code == 2 and "--caliscope-folds: given (caliscope starts from" in result.output
    result = CliRunner().invoke(app, ["calibrate", str(SESSION), "--out", str(out), "--caliscope-folds", "given"])
    assert result.exit_code == 2 and not out.exists()
    assert ("--caliscope-folds given: give the intrinsics" if caliscope_available()
            else "pip install -e '.[caliscope]'") in result.output


def test_the_fit_choice_prints_every_candidate_and_the_one_chosen():
    from gaitcap.reconstruction.calibration.model_choice import FitChoice
    from gaitcap.services.cli.calibrate import _fit_choice

    fit = FitChoice(("given intrinsics held, soft-L1 (1 px)", "given intrinsics held, least squares"), (1.011, 0.995),
                    {"cam_0": (1.0, 0.99)}, {}, "given intrinsics held, least squares", "", 5, 30.0)
    text = _fit_choice(fit).splitlines()
    assert text[0].startswith("fit chosen by held-out error (5 folds in time, 2 candidates")
    assert "  given intrinsics held, least squares: 0.995  <- chosen" in text
    assert "  given intrinsics held, soft-L1 (1 px): 1.011" in text


def test_where_the_rigs_differ_the_held_out_error_on_equal_terms_says_which_is_right():
    from types import SimpleNamespace

    from gaitcap.services.cli.calibrate import _which_is_right

    near = SimpleNamespace(centre_mm_max=1.3, rotation_deg_max=0.22)
    apart = SimpleNamespace(centre_mm_max=16.3, rotation_deg_max=2.49)
    own = SimpleNamespace(rms_px=1.075, label="this calibration")
    theirs = SimpleNamespace(rms_px=1.014, label="caliscope's calibration (intrinsics given)")
    given = SimpleNamespace(rms_px=0.896, label="reference camera_array.toml")
    assert _which_is_right(near, SimpleNamespace(own=own, reference=given, refitted=theirs)) == ""
    line = _which_is_right(apart, SimpleNamespace(own=own, reference=given, refitted=theirs))
    assert line.startswith("the rigs differ by 16.3 mm / 2.49 deg (more than 15 mm or 1 deg)")
    assert "favours caliscope's calibration (intrinsics given) (1.075 against 1.014 px; both fitted on each fold" in line
    line = _which_is_right(apart, SimpleNamespace(own=SimpleNamespace(rms_px=0.85, label=""), reference=given,
                                                  refitted=None))
    assert "favours this calibration (0.850 against 0.896 px; the reference judged on the same frame sets, " \
        "in-sample for it" in line
    assert "--caliscope-folds" in _which_is_right(apart, "held-out error not measured: too few frame sets")
