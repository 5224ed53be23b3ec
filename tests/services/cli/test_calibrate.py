"""``gaitcap calibrate`` on a simulated board recording (MCAP written like the recorder's)."""

import json

import numpy as np
import pytest
from gaitcap.acquisition.readers import load_rig
from gaitcap.acquisition.synthetic.board import write_board_mcap
from gaitcap.reconstruction.calibration.geometry import rotation_angle_deg
from gaitcap.services.cli import app
from typer.testing import CliRunner

from ..conftest import board_images

SCALE = 0.3


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    images, truth = board_images(SCALE)
    return write_board_mcap(tmp_path_factory.mktemp("cal") / "board.mcap", images), truth


def test_calibrate_writes_calibration_and_report(recording, tmp_path):
    mcap, truth = recording
    out = tmp_path / "calib.toml"
    result = CliRunner().invoke(app, ["calibrate", str(mcap), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "reprojection RMS" in result.output and "cam02" in result.output
    rig = load_rig(out)
    assert rig.names == ["cam01", "cam02"]
    for true, got in zip(truth, rig, strict=True):  # a short, low-resolution clip: a plumbing check
        assert np.linalg.norm(true.center_mm - got.center_mm) < 100, true.name
        assert rotation_angle_deg(true.rotation, got.rotation) < 1.0, true.name
    report = json.loads((tmp_path / "calib.report.json").read_text())
    assert [c["name"] for c in report["cameras"]] == ["cam01", "cam02"]
    assert report["reprojection_rms_px"] < 0.5 and report["board"].startswith("checkerboard 7x5")


def test_wrong_board_is_a_clear_error(recording, tmp_path):
    mcap, _ = recording
    result = CliRunner().invoke(app, ["calibrate", str(mcap), "--squares", "8x6", "--out", str(tmp_path / "c.toml"),
                                      "--max-frames", "3"])
    assert result.exit_code == 2
    assert "camera 'cam01': no frame showed the whole 8x6-square checkerboard" in result.output
    assert "camera 'cam02'" in result.output and "board size" not in result.output
    assert not (tmp_path / "c.toml").exists()
