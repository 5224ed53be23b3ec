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


def test_the_table_names_the_views_left_out_for_passed_and_failed_cameras():
    from gaitcap.reconstruction.calibration import CameraQuality, QualityReport
    from gaitcap.reconstruction.calibration.whole_views import LEFT_OUT_REASON
    from gaitcap.services.cli.calibrate import _summary

    note = (f"3 views left out: {LEFT_OUT_REASON}",)
    cams = (CameraQuality("cam01", 20, 480, 2, 0.3, 0.6, 0.4, 0.5, True, (), 0.3, 23, 20 / 23, 3, note),
            CameraQuality("cam02", 20, 480, 9, 0.9, 3.5, 1.2, 0.5, False, ("reprojection p95 3.50 px > 3.0 px",),
                          0.8, 23, 20 / 23, 3, note),
            CameraQuality("cam03", 23, 552, 0, 0.3, 0.6, 0.4, 0.5, True, (), 0.3, 23, 1.0))
    report = QualityReport("board", "k1", cams, ("cam02",), 30, 1512, 11, 0.5, 1.2, 0.7, 110.0, 110.1, 0.1, 5,
                           False, 3, 1.0)
    rows = {line.split()[0]: line for line in _summary(report).splitlines()[1:4]}
    assert rows["cam01"].endswith(f"ok; 3 views left out: {LEFT_OUT_REASON}"), rows["cam01"]
    assert rows["cam02"].endswith(f"FAILED: reprojection p95 3.50 px > 3.0 px; 3 views left out: {LEFT_OUT_REASON}")
    assert rows["cam03"].endswith("  ok")
