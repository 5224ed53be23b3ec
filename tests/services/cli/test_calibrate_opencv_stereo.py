"""``gaitcap calibrate`` on real images with nothing but the board's description: OpenCV's stereo sample
(two cameras, 13 synchronised 640x480 views of a 9 x 6 inner-corner checkerboard of 25 mm squares, from
Debian's opencv-doc, installed by deploy/bootstrap.sh), compared with OpenCV's own calibration of the
same images."""

import json

import numpy as np
import pytest
from gaitcap.acquisition.boards.detection import BoardConfig
from gaitcap.acquisition.importers.opencv_samples import opencv_stereo_calibration, read_opencv_camera
from gaitcap.acquisition.installed import share_path
from gaitcap.acquisition.readers import load_rig
from gaitcap.acquisition.writers import save_rig
from gaitcap.reconstruction.calibration.compare import stereo_difference
from gaitcap.services.cli import app
from typer.testing import CliRunner

PAIR = share_path("testdata", "calibration", "opencv-stereo")
pytestmark = pytest.mark.skipif(not (PAIR / "left_intrinsics.yml").exists(),
                                reason=f"OpenCV's stereo sample not installed in {PAIR} (run deploy/bootstrap.sh)")


def test_the_pair_calibrates_like_opencv_calibrates_it(tmp_path):
    opencv = opencv_stereo_calibration(sorted((PAIR / "left").glob("*.jpg")), sorted((PAIR / "right").glob("*.jpg")),
                                       board=BoardConfig.checkerboard(10, 7, 25.0))
    out, reference = tmp_path / "calib.toml", save_rig(opencv.rig, tmp_path / "opencv.toml")
    result = CliRunner().invoke(app, ["calibrate", str(PAIR), "--squares", "10x7", "--square-mm", "25",
                                      "--distortion", "k1k2p1p2k3", "--out", str(out), "--compare", str(reference),
                                      "--folds", "0"])
    assert result.exit_code == 0, result.output
    report = json.loads((tmp_path / "calib.report.json").read_text())
    cams = {c["name"]: c for c in report["cameras"]}
    # the sample's 13 pairs were chosen with the whole board in both views: every one must be found
    assert {n: c["n_detections"] for n, c in cams.items()} == {"left": 13, "right": 13}
    assert all(c["ok"] for c in cams.values()) and not report["failed_cameras"]
    assert max(c["reprojection_rms_px"] for c in cams.values()) < 0.35  # measured 0.255 / 0.256 px
    assert abs(report["square_measured_mm"] - 25.0) < 0.1  # measured 25.01 mm

    rig = load_rig(out)
    assert opencv.views == 13 and opencv.stereo_rms_px < 0.5  # OpenCV's own fit: 0.44 px
    diff = stereo_difference(load_rig(reference), rig, first="left", second="right")
    # measured: baselines 82.88 (ours) vs 83.45 mm (OpenCV), the right camera's centre 0.70 mm and its turn 0.21 deg apart
    assert diff.centre_mm < 1.5 and diff.rotation_deg < 0.5 and abs(diff.baseline_mm - 83.45) < 1.0
    # --compare prints that pair geometry (a similarity alignment would need a third camera)
    assert (f"baseline {diff.baseline_mm:.2f} mm vs {diff.reference_baseline_mm:.2f} mm in the reference; right's "
            f"centre {diff.centre_mm:.2f} mm and its rotation {diff.rotation_deg:.3f} deg") in result.output

    # OpenCV's shipped calibration of the left camera from the same 13 images (aspect ratio held at 1):
    # focal length within 1 % (measured -0.55 %), principal point within 2 px (measured 0.1 / 1.2 px)
    sample = read_opencv_camera(PAIR / "left_intrinsics.yml", name="left")
    left = rig["left"]
    assert abs(left.matrix_px[0, 0] / sample.matrix_px[0, 0] - 1) < 0.01
    assert np.abs(left.matrix_px[:2, 2] - sample.matrix_px[:2, 2]).max() < 2.0
