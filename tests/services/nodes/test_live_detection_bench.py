"""The live detection benchmark, short: 2 of Pose2Sim's real calibrated demo cameras for 3 s through the real
MediaPipe detector pool and recorder (real processes), then the worker's processing after Stop (preliminary,
completion, refined): every recorded frame ends with keypoints, frame for frame those of ``gaitcap detect``."""

import importlib.util
import sys
from pathlib import Path

import pytest
from gaitcap.acquisition.detectors.mediapipe import default_model_dir
from gaitcap.acquisition.installed import share_path

BENCH = Path(__file__).resolve().parents[3] / "bench" / "live_detection.py"


@pytest.mark.skipif(not (default_model_dir() / "pose_landmark_lite.tflite").is_file()
                    or not share_path("testdata", "pose2sim", "Demo_SinglePerson", "videos").is_dir(),
                    reason="MediaPipe models / test video not installed (run deploy/bootstrap.sh)")
def test_two_cameras_three_seconds_end_fully_detected_and_refined():
    spec = importlib.util.spec_from_file_location("live_detection_bench", BENCH)
    bench = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = bench  # its dataclasses look their module up
    spec.loader.exec_module(bench)
    r = bench.run(source="pose2sim", cameras=2, seconds=3.0, workers=1, model="lite", check=True)
    assert set(r["per_camera"]) == {"cam01", "cam02"}
    assert r["frames_recorded"] >= 2 * 80, r  # 90 frames per camera at 30 fps, a few may be late
    assert r["frames_live"] > 0 and r["final_coverage"] == 1.0 and r["targets_met"]["final_coverage_100pct"]
    for row in r["per_camera"].values():
        assert row["completed"] == row["recorded"] and row["corrupt"] == row["missing"] == 0  # every frame again
        assert row["lag_s"] is not None and row["lag_s"] >= 0
    assert r["stages_failed"] == {} and 0 < r["stop_to_preliminary_s"] <= r["stop_to_complete_s"] <= r[
        "stop_to_refined_s"] <= r["stop_to_all_done_s"], r
    assert r["targets_met"]["stop_to_refined_within_3min"], r
    same = r["agreement_with_detect"]["recorded images"]  # the detector on the JPEG frames, as gaitcap detect runs
    assert same["frames"]["best_offset"] == 0 and same["completed"]["identical"] == 1.0, same
    assert same["completed"]["frames_compared"] >= 2 * 80 and same["completed"]["found_by_one_only"] == 0, same
    assert "refined stored" in bench.table(r)
