"""The live detection benchmark, short: 2 video cameras for 2 s through the real MediaPipe detector pool and
recorder (real processes), then the completion after Stop: every recorded frame ends with keypoints."""

import importlib.util
from pathlib import Path

import pytest
from gaitcap.acquisition.detectors.mediapipe import default_model_dir
from gaitcap.acquisition.installed import share_path

BENCH = Path(__file__).resolve().parents[3] / "bench" / "live_detection.py"


@pytest.mark.skipif(not (default_model_dir() / "pose_landmark_lite.tflite").is_file()
                    or not share_path("testdata", "sports2d-demo.mp4").is_file(),
                    reason="MediaPipe models / test video not installed (run deploy/bootstrap.sh)")
def test_two_cameras_two_seconds_end_fully_detected():
    spec = importlib.util.spec_from_file_location("live_detection_bench", BENCH)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    r = bench.run(cameras=2, seconds=2.0, workers=1, model="lite", check=False)
    assert set(r["per_camera"]) == {"cam01", "cam02"}
    assert r["frames_recorded"] >= 2 * 50, r  # 60 frames per camera at 30 fps, a few may be late
    assert r["frames_live"] > 0 and r["final_coverage"] == 1.0 and r["targets_met"]["final_coverage_100pct"]
    for row in r["per_camera"].values():
        assert row["live"] + row["completed"] == row["recorded"] and row["corrupt"] == row["missing"] == 0
        assert row["lag_s"] is not None and row["lag_s"] >= 0
    assert "Stop -> complete detection" in bench.table(r)
