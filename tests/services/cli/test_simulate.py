"""``gaitcap simulate-board`` writes a calibration recording and its truth; ``gaitcap calibrate
--compare`` then reports how far the calibration is from it (a short low-resolution clip here; the
accuracy targets are measured at full resolution by bench/calibration.py)."""

import re

from gaitcap.acquisition.readers import load_rig
from gaitcap.reconstruction.calibration.compare import compare_rigs
from gaitcap.services.cli import app
from typer.testing import CliRunner


def test_simulated_board_recording_calibrates_close_to_its_truth(tmp_path):
    sim = tmp_path / "sim"
    result = CliRunner().invoke(app, ["simulate-board", "--out", str(sim), "--cameras", "3", "--frames", "90",
                                      "--floor-frames", "4", "--scale", "0.3"])
    assert result.exit_code == 0, result.output
    assert (sim / "board.mcap").is_file() and "576x360 px" in result.output
    truth = load_rig(sim / "true_calibration.toml")
    assert truth.names == ["cam01", "cam02", "cam03"] and truth[0].size_px == (576, 360)

    out = tmp_path / "cal.toml"
    result = CliRunner().invoke(app, ["calibrate", str(sim / "board.mcap"), "--out", str(out),
                                      "--compare", str(sim / "true_calibration.toml"), "--folds", "0"])
    assert result.exit_code == 0, result.output
    cmp = compare_rigs(truth, load_rig(out))
    printed = re.search(r"max: centre ([\d.]+) mm, rotation ([\d.]+) deg", result.output)
    assert printed is not None, result.output
    assert abs(float(printed[1]) - cmp.centre_mm_max) < 0.01 and abs(float(printed[2]) - cmp.rotation_deg_max) < 1e-3
    assert cmp.centre_mm_max < 30 and cmp.rotation_deg_max < 0.5  # 90 frames at 576x360 px (measured: 10 mm, 0.15 deg)
    assert cmp.aligned_centre_mm_max < 10


def test_simulate_board_bad_option_is_named(tmp_path):
    result = CliRunner().invoke(app, ["simulate-board", "--out", str(tmp_path / "s"), "--board", "dots"])
    assert result.exit_code == 2 and "--board" in result.output
    result = CliRunner().invoke(app, ["simulate-board", "--out", str(tmp_path / "s"), "--frames", "10"])
    assert result.exit_code == 2 and "frames (10)" in result.output
    assert not (tmp_path / "s" / "board.mcap").exists()
