"""Completion after Stop: the frames without live keypoints detected from the recording's images."""

import json

import cv2
import numpy as np
import pytest
from gaitcap.acquisition.detectors.mediapipe import MediaPipeConfig, default_model_dir
from gaitcap.acquisition.encoding import decode_jpeg, encode_jpeg, image_message
from gaitcap.acquisition.installed import share_path
from gaitcap.acquisition.readers import load_multi_npz
from gaitcap.acquisition.recording.reader import read_keypoints
from gaitcap.acquisition.recording.writer import TrialWriter
from gaitcap.reconstruction.keypoints import COMPLETED, LIVE, MISSING, MultiViewKeypoints, missing_keypoints
from gaitcap.reconstruction.skeletons import get_skeleton
from gaitcap.services.processing.completion import complete_keypoints, save_completion

T0, PERIOD = 1_700_000_000_000_000_000, 33_333_333
VIDEO = share_path("testdata", "sports2d-demo.mp4")


class Brightness:
    """One person whose x is the image's mean grey level (px) and y its frame id: which image was detected."""

    skeleton = get_skeleton("coco17")

    def detect(self, image_bgr, *, camera, frame_id, timestamp_ns):
        return np.tile([[float(image_bgr.mean()), float(frame_id), 0.9]], (1, 17, 1))


def _grey(level):
    return encode_jpeg(np.full((24, 32, 3), level, np.uint8))


def _write(path, images, keypoints):
    """images: {camera: {frame id: jpeg}}; keypoints: {camera: {frame id: people}} (the live ones)."""
    w = TrialWriter(path)
    w.start(metadata={"trial_id": "t"}, time_ns=T0)
    for f in range(max(max(v) for v in images.values()) + 1):
        for cam in sorted(images):
            ts = T0 + f * PERIOD
            if f in images[cam]:
                w.add_frame(cam, image_message(images[cam][f], camera=cam, timestamp_ns=ts), timestamp_ns=ts,
                            frame_id=f, receive_ns=ts)
            if f in keypoints.get(cam, {}):
                kp = {"camera": cam, "frame_id": f, "timestamp_ns": ts, "skeleton": "coco17",
                      "people": keypoints[cam][f]}
                w.add_keypoints(cam, json.dumps(kp).encode(), timestamp_ns=ts, frame_id=f)
    return w.finish({})


def test_missing_frames_and_live_frames_with_nobody_are_completed_the_live_ones_kept_and_a_corrupt_image_named(
        tmp_path):
    levels = {"cam0": 40, "cam1": 200}
    images = {c: {f: _grey(lv + f) for f in range(12)} for c, lv in levels.items()}
    images["cam1"][5] = b"\xff\xd8 not a jpeg"  # a corrupt image in the recording
    live_person = [[[1.0, 2.0, 0.5]] * 17]
    live = {"cam0": {f: live_person for f in range(2, 6)}, "cam1": {3: []}}  # cam1 frame 3: live found nobody
    path = _write(tmp_path / "t.mcap", images, live)
    recording = read_keypoints(path)
    assert recording.frame_ids.tolist() == [2, 3, 4, 5]  # what the live pass caught

    kp, report = complete_keypoints(path, recording, Brightness, detector_name="brightness", workers=0)
    assert kp.frame_ids.tolist() == list(range(12)) and kp.camera_names == ("cam0", "cam1")
    cam0, cam1 = report.cameras
    assert (cam0.recorded, cam0.live, cam0.completed, cam0.corrupt_frame_ids) == (12, 4, 8, ())
    assert (cam1.recorded, cam1.live, cam1.completed, cam1.corrupt_frame_ids) == (12, 0, 11, (5,))  # 3 again
    assert cam1.missing_frame_ids == (5,) and not report.complete
    np.testing.assert_allclose(kp.keypoints[0, 2:6, 0], np.broadcast_to(live_person[0], (4, 17, 3)))  # live kept
    for c, cam in enumerate(kp.camera_names):
        for f in range(12):
            if report.provenance[c, f] == COMPLETED:
                want = decode_jpeg(images[cam][f]).mean()
                assert kp.keypoints[c, f, 0, 0, :2].tolist() == pytest.approx([want, f])
                assert kp.timestamps_ns[c, f] == T0 + f * PERIOD
    assert report.provenance[1, 5] == MISSING and report.provenance[1, 3] == COMPLETED
    assert report.provenance[0, 2] == LIVE
    assert kp.provenance.tolist() == report.provenance.tolist()  # the keypoints say where each frame came from
    assert np.isnan(kp.keypoints[1, 5]).all() or (kp.keypoints[1, 5, ..., 2] == 0).all()
    assert np.allclose(np.diff(kp.times_s), PERIOD / 1e9)
    body = report.to_dict()
    assert body["frames"] == {"recorded": 24, "live": 4, "completed": 19, "corrupt": 1, "live_pass": 5}
    assert body["cameras"]["cam1"]["corrupt_frame_ids"] == [5]
    assert body["cameras"]["cam0"]["completed_frame_ids"] == [[0, 1], [6, 11]]

    files = save_completion(tmp_path / "trial", kp, report)
    multi = load_multi_npz(files.keypoints)  # a multi-person keypoint file: where each frame came from too
    assert multi.keypoints.shape == kp.keypoints.shape and list(multi.camera_names) == ["cam0", "cam1"]
    assert multi.provenance.tolist() == report.provenance.tolist()
    assert multi.frame_ids.tolist() == kp.frame_ids.tolist() and (multi.timestamps_ns == kp.timestamps_ns).all()
    with np.load(files.keypoints) as z:
        assert str(z["detector"]) == "brightness"
    assert json.loads(files.report.read_text())["cameras"]["cam1"]["missing"] == 1


def test_redetect_all_ignores_the_live_keypoints_and_works_without_any(tmp_path):
    images = {"cam0": {f: _grey(30 + f) for f in range(5)}}
    path = _write(tmp_path / "t.mcap", images, {})
    kp, report = complete_keypoints(path, None, Brightness, detector_name="brightness", workers=0, redetect_all=True)
    assert (report.provenance == COMPLETED).all() and report.complete and kp.skeleton.name == "coco17"
    assert report.cameras[0].completed == 5 and report.cameras[0].live == 0


def test_a_live_skeleton_other_than_the_detectors_is_refused(tmp_path):
    images = {"cam0": {f: _grey(30) for f in range(3)}}
    path = _write(tmp_path / "t.mcap", images, {"cam0": {0: []}})
    rec = read_keypoints(path)
    rec = MultiViewKeypoints(missing_keypoints((1, rec.shape[1], 0, 26)), rec.camera_names, rec.times_s, "halpe26",
                             frame_ids=rec.frame_ids, timestamps_ns=rec.timestamps_ns)
    with pytest.raises(ValueError, match="live keypoints are halpe26, the completion detector brightness gives coco17"):
        complete_keypoints(path, rec, Brightness, detector_name="brightness", workers=0)


@pytest.mark.skipif(not (default_model_dir() / "pose_landmark_lite.tflite").is_file() or not VIDEO.is_file(),
                    reason="MediaPipe models / test video not installed (run deploy/bootstrap.sh)")
def test_real_mediapipe_in_two_worker_processes_equals_the_detector_on_the_same_images(tmp_path):
    cap = cv2.VideoCapture(str(VIDEO))
    cap.set(cv2.CAP_PROP_POS_FRAMES, 100)
    frames = [cv2.resize(cap.read()[1], (480, 270)) for _ in range(6)]
    cap.release()
    jpegs = [encode_jpeg(f) for f in frames]
    images = {cam: dict(enumerate(jpegs)) for cam in ("left", "right")}
    path = _write(tmp_path / "t.mcap", images, {})
    config = MediaPipeConfig(model="lite", num_threads=1)
    kp, report = complete_keypoints(path, None, config.build, detector_name="mediapipe lite", workers=2,
                                    redetect_all=True)
    assert report.complete and report.workers == 2
    det = config.build()  # the same detector, frame after frame, on the same images
    for c, cam in enumerate(kp.camera_names):
        for f, jpeg in enumerate(jpegs):
            want = det.detect(decode_jpeg(jpeg), camera=cam, frame_id=f, timestamp_ns=0)
            assert len(want) >= 1, "the walker is in these frames"
            np.testing.assert_allclose(kp.keypoints[c, f, : len(want)], want, atol=1e-6)
            assert (kp.keypoints[c, f, len(want):, :, 2] == 0).all()


def test_complete_trial_with_settings_stores_the_files(tmp_path):
    from dataclasses import dataclass

    from gaitcap.acquisition.detectors.base import DetectorConfig
    from gaitcap.services.processing.completion import CompletionSettings, complete_trial

    @dataclass(frozen=True)
    class BrightnessConfig(DetectorConfig):
        kind = "brightness"
        gain: float = 1.0

        def build(self):
            return Brightness()

    images = {"cam0": {f: _grey(60 + f) for f in range(4)}}
    path = _write(tmp_path / "t.mcap", images, {"cam0": {1: [[[1.0, 2.0, 0.5]] * 17]}})
    settings = CompletionSettings(BrightnessConfig(gain=2.0), workers=0)
    assert settings.detector_name == "brightness gain=2.0"
    kp, report, files = complete_trial(path, read_keypoints(path), tmp_path / "trial", settings)
    assert report.detector == "brightness gain=2.0" and report.provenance.tolist() == [[2, 1, 2, 2]]
    assert files.keypoints.is_file() and files.report.is_file() and kp.frame_ids.tolist() == [0, 1, 2, 3]


def test_settings_can_redetect_every_frame_the_live_ones_too(tmp_path):
    from dataclasses import dataclass

    from gaitcap.acquisition.detectors.base import DetectorConfig
    from gaitcap.services.processing.completion import CompletionSettings, complete_trial

    @dataclass(frozen=True)
    class BrightnessConfig(DetectorConfig):
        kind = "brightness"

        def build(self):
            return Brightness()

    images = {"cam0": {f: _grey(60 + f) for f in range(4)}}
    path = _write(tmp_path / "t.mcap", images, {"cam0": {1: [[[1.0, 2.0, 0.5]] * 17]}})
    kp, report, _ = complete_trial(path, read_keypoints(path), tmp_path / "trial",
                                   CompletionSettings(BrightnessConfig(), workers=0, redetect_all=True))
    assert report.provenance.tolist() == [[2, 2, 2, 2]] and report.redetected_all
    assert kp.keypoints[0, 1, 0, 0, 0] == pytest.approx(decode_jpeg(images["cam0"][1]).mean())
    row = report.to_dict()["cameras"]["cam0"]  # the live pass's coverage survives the frames detected again
    assert (row["live"], row["completed"], row["live_pass"], row["live_coverage"]) == (0, 4, 1, 0.25)

    from gaitcap.services.processing.checks import completion_check

    note = completion_check(report)["notes"][0]
    assert "4 of 4 recorded frames were detected again after Stop" in note and "25.0 % live coverage" in note
