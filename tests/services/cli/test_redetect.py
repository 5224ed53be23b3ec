"""`gaitcap redetect TRIAL.mcap`: a stored trial detected again from its recorded images with real MediaPipe."""

import json

import cv2
import numpy as np
import pytest
from gaitcap.acquisition.detectors.mediapipe import default_model_dir
from gaitcap.acquisition.encoding import encode_jpeg, image_message
from gaitcap.acquisition.installed import share_path
from gaitcap.acquisition.recording.writer import TrialWriter
from gaitcap.services.cli import app
from typer.testing import CliRunner

VIDEO = share_path("testdata", "sports2d-demo.mp4")
T0, PERIOD = 1_700_000_000_000_000_000, 33_333_333

pytestmark = pytest.mark.skipif(not (default_model_dir() / "pose_landmark_lite.tflite").is_file() or not VIDEO.is_file(),
                                reason="MediaPipe models / test video not installed (run deploy/bootstrap.sh)")


def _trial(path, frames=4):
    cap = cv2.VideoCapture(str(VIDEO))
    cap.set(cv2.CAP_PROP_POS_FRAMES, 100)
    jpegs = [encode_jpeg(cv2.resize(cap.read()[1], (480, 270))) for _ in range(frames)]
    cap.release()
    w = TrialWriter(path)
    w.start(metadata={"trial_id": "t"}, time_ns=T0)
    for f, jpeg in enumerate(jpegs):
        for cam in ("cam01", "cam02"):
            ts = T0 + f * PERIOD
            data = b"\xff\xd8broken" if (cam, f) == ("cam02", 2) else jpeg
            w.add_frame(cam, image_message(data, camera=cam, timestamp_ns=ts), timestamp_ns=ts, frame_id=f,
                        receive_ns=ts)
    return w.finish({})


def test_redetect_a_whole_trial_names_the_corrupt_frame(tmp_path):
    path = _trial(tmp_path / "trial.mcap")
    out = tmp_path / "again"
    res = CliRunner().invoke(app, ["redetect", str(path), "--detector", "mediapipe", "--model", "lite",
                                   "--workers", "1", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "8 recorded, 0 live, 7 detected, 1 corrupt" in res.output
    report = json.loads((out / "completion.json").read_text())
    assert report["detector"] == "mediapipe lite" and report["redetected_all"] is True
    assert report["cameras"]["cam02"]["corrupt_frame_ids"] == [2] and report["cameras"]["cam01"]["coverage"] == 1.0
    with np.load(out / "keypoints_complete.npz") as z:
        assert z["keypoints"].shape[:2] == (2, 4) and str(z["skeleton"]) == "mediapipe33"
        assert (z["keypoints"][0, :, 0, :, 2] > 0.5).mean() > 0.5  # the walker found in cam01's frames


def test_a_missing_recording_is_named(tmp_path):
    res = CliRunner().invoke(app, ["redetect", str(tmp_path / "nope.mcap"), "--out", str(tmp_path / "o")])
    assert res.exit_code != 0 and "nope.mcap" in res.output


def test_several_trials_one_task_each_a_bad_one_fails_alone(tmp_path):
    for name in ("T1", "T2"):
        (tmp_path / name).mkdir()
        _trial(tmp_path / name / "recording.mcap", frames=3)
    out = tmp_path / "again"
    args = ["redetect", str(tmp_path / "T1" / "recording.mcap"), str(tmp_path / "T2" / "recording.mcap"),
            str(tmp_path / "T3.mcap"), "--model", "lite", "--workers", "0", "--out", str(out)]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 1, res.output
    assert f"{out / 'T1'}: done: 5 frames detected, 1 corrupt" in res.output
    assert f"{out / 'T3'}: failed: FileNotFoundError: recording {tmp_path / 'T3.mcap'} not found" in res.output
    assert json.loads((out / "T2" / "completion.json").read_text())["cameras"]["cam02"]["corrupt_frame_ids"] == [2]


def test_two_trials_writing_into_one_folder_are_refused(tmp_path):
    from gaitcap.acquisition.detectors.mediapipe import MediaPipeConfig
    from gaitcap.services.processing.completion import CompletionSettings
    from gaitcap.services.research.redetect import plan_redetect

    with pytest.raises(ValueError, match="would both write into"):
        plan_redetect(["a/x.mcap", "b/x.mcap"], tmp_path, CompletionSettings(MediaPipeConfig()))
