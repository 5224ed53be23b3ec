"""``gaitcap calibrate`` on a simulated board recording (MCAP written like the recorder's)."""

import json

import numpy as np
import pytest
from gaitcap.acquisition.readers import load_rig
from gaitcap.acquisition.writers import save_rig
from gaitcap.reconstruction.calibration.compare import stereo_difference
from gaitcap.reconstruction.calibration.geometry import rotation_angle_deg
from gaitcap.services.cli import app
from gaitcap.simulator.board import write_board_folder, write_board_mcap
from typer.testing import CliRunner

from ..conftest import board_images

SCALE = 0.3


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    images, truth = board_images(SCALE)
    return write_board_mcap(tmp_path_factory.mktemp("cal") / "board.mcap", images), truth


def test_calibrate_writes_calibration_and_report(recording, tmp_path):
    mcap, truth = recording
    out, reference = tmp_path / "calib.toml", save_rig(truth, tmp_path / "truth.toml")
    result = CliRunner().invoke(app, ["calibrate", str(mcap), "--out", str(out), "--compare", str(reference),
                                      "--folds", "400"])
    assert result.exit_code == 0, result.output
    # too few frame sets for the folds asked: the calibration stands, the held-out error says why not
    assert "held-out error not measured: held-out error: " in result.output and "fewer than the 400 folds" in result.output
    assert "reprojection RMS" in result.output and "cam02" in result.output
    rig = load_rig(out)
    # two cameras: the pair's own geometry against the reference's (a similarity alignment needs three)
    pair = stereo_difference(load_rig(reference), rig, first="cam01", second="cam02")
    assert (f"the pair's own geometry (cam02 seen from cam01): baseline {pair.baseline_mm:.2f} mm vs "
            f"{pair.reference_baseline_mm:.2f} mm in the reference; cam02's centre {pair.centre_mm:.2f} mm and its "
            f"rotation {pair.rotation_deg:.3f} deg from the reference's") in result.output
    assert pair.centre_mm < 100 and pair.rotation_deg < 1.0 and "similarity alignment" not in result.output
    assert rig.names == ["cam01", "cam02"]
    for true, got in zip(truth, rig, strict=True):  # a short, low-resolution clip: a plumbing check
        assert np.linalg.norm(true.center_mm - got.center_mm) < 100, true.name
        assert rotation_angle_deg(true.rotation, got.rotation) < 1.0, true.name
    report = json.loads((tmp_path / "calib.report.json").read_text())
    assert [c["name"] for c in report["cameras"]] == ["cam01", "cam02"]
    assert report["reprojection_rms_px"] < 0.5 and report["board"].startswith("checkerboard 7x5")
    assert report["held_out"].startswith("held-out error not measured: ")


def test_wrong_board_is_a_clear_error(recording, tmp_path):
    mcap, _ = recording
    result = CliRunner().invoke(app, ["calibrate", str(mcap), "--squares", "8x6", "--out", str(tmp_path / "c.toml"),
                                      "--max-frames", "3"])
    assert result.exit_code == 2
    assert "camera 'cam01': no frame showed the whole 8x6-square checkerboard" in result.output
    assert "camera 'cam02'" in result.output and "board size" not in result.output
    assert not (tmp_path / "c.toml").exists()


def test_options_that_need_frame_times_are_a_usage_error_on_image_folders_without_them(tmp_path):
    images, _ = board_images(SCALE)
    folder = write_board_folder(tmp_path / "board", {cam: frames[:2] for cam, frames in images.items()})
    result = CliRunner().invoke(app, ["calibrate", str(folder), "--readout-ms", "20", "--out", str(tmp_path / "c.toml")])
    assert result.exit_code == 2
    assert (f"error: {folder}: the frames of cameras ['cam01', 'cam02'] carry no timestamps, so the cameras are "
            "paired by order") in result.output
    assert "readout_ms 20 (--readout-ms) needs frame times; add (or correct) a timestamps.csv" in result.output
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
    assert rows["cam01"].endswith(f"ok | note: 3 views left out: {LEFT_OUT_REASON}"), rows["cam01"]
    assert rows["cam02"].endswith(f"FAILED: reprojection p95 3.50 px > 3.0 px | note: 3 views left out: {LEFT_OUT_REASON}")
    assert rows["cam03"].endswith("  ok")
