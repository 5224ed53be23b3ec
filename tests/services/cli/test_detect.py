"""`gaitcap detect --videos DIR`: a detector defined here finds a bright square in each camera's video."""

from dataclasses import dataclass

import cv2
import numpy as np
import pytest
from gaitcap.acquisition.detectors.base import DETECTOR_CONFIGS, DetectorConfig
from gaitcap.acquisition.installed import share_path
from gaitcap.acquisition.readers import load_multi_npz
from gaitcap.acquisition.video_detect import detect_videos, find_videos
from gaitcap.reconstruction.skeletons import get_skeleton
from gaitcap.services.cli import app
from typer.testing import CliRunner

SQ = 8


class BlobDetector:
    """Every joint at the centre of the bright square; a second, fainter 'person' in odd frames."""

    skeleton = get_skeleton("coco17")

    def detect(self, image_bgr, *, camera, frame_id, timestamp_ns):
        ys, xs = np.nonzero(image_bgr[..., 1] > 128)
        if xs.size == 0:
            return np.zeros((0, 17, 3))
        one = np.tile([[xs.mean(), ys.mean(), 0.9]], (17, 1))
        if frame_id % 2:
            return np.stack([one * [1, 1, 0.3 / 0.9], one])  # the patient second: chosen by confidence
        return one[None]


@dataclass(frozen=True)
class BlobConfig(DetectorConfig):
    kind = "test-blob"
    model_path: str = ""

    def build(self):
        return BlobDetector()


def _one_person(path):
    """The first (most confident) person of a detect output as one person's detections."""
    multi = load_multi_npz(path)
    return multi.patient()


def _video(path, n, fps, dx):
    out = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, (64, 48))
    for i in range(n):
        img = np.zeros((48, 64, 3), np.uint8)
        x = 4 + 2 * i + dx
        img[20 : 20 + SQ, x : x + SQ] = 255
        out.write(img)
    out.release()


def test_detect_command_writes_the_reconstruction_input(tmp_path, monkeypatch):
    monkeypatch.setitem(DETECTOR_CONFIGS, "test-blob", BlobConfig)
    vids = tmp_path / "vids"
    vids.mkdir()
    _video(vids / "left.avi", 12, 30, 0)
    _video(vids / "right.avi", 10, 30, 10)
    (vids / "notes.txt").write_text("not a video")
    out, one = tmp_path / "kp.npz", tmp_path / "one.npz"
    res = CliRunner().invoke(app, ["detect", "--videos", str(vids), "--detector", "test-blob", "--model", "x.onnx",
                                   "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "up to 1 people per camera frame" in res.output  # the faint one is below 0.5
    multi = load_multi_npz(out)  # everyone by default, most confident first
    assert multi.camera_names == ("left", "right") and multi.keypoints.shape == (2, 12, 2, 17, 3)
    np.testing.assert_allclose(np.diff(multi.times_s), 1 / 30, rtol=1e-6)
    np.testing.assert_allclose(multi.keypoints[0, :, 0, 0, 0], 4 + 2 * np.arange(12) + (SQ - 1) / 2, atol=0.6)
    np.testing.assert_allclose(multi.keypoints[0, :, 0, 0, 2], 0.9)  # the confident person first, odd frames too
    np.testing.assert_allclose(multi.keypoints[0, 1::2, 1, 0, 2], 0.3)  # the faint one is kept, second
    assert (multi.keypoints[1, 10:, :, :, 2] == 0).all()  # the shorter file is padded as missing
    res = CliRunner().invoke(app, ["detect", "--videos", str(vids), "--detector", "test-blob", "--model", "x.onnx",
                                   "--out", str(one), "--one-per-camera"])
    assert res.exit_code == 0, res.output
    det = load_multi_npz(one)
    assert det.keypoints.shape == (2, 12, 1, 17, 3)
    np.testing.assert_allclose(det.keypoints[0, :, 0, 0, 2], 0.9)


def test_bad_folders_and_rates(tmp_path):
    runner = CliRunner()
    res = runner.invoke(app, ["detect", "--videos", str(tmp_path / "none"), "--out", str(tmp_path / "o.npz")])
    assert res.exit_code == 2 and "does not exist" in res.output
    with pytest.raises(ValueError, match="no video files"):
        find_videos(tmp_path)
    _video(tmp_path / "a.avi", 3, 30, 0)
    _video(tmp_path / "b.avi", 3, 15, 0)
    with pytest.raises(ValueError, match="different frame rates"):
        detect_videos(find_videos(tmp_path), BlobDetector())
    assert detect_videos(find_videos(tmp_path), BlobDetector(), fps=30).fps_hz == pytest.approx(30, rel=1e-12)


def _demo_clips(folder, first=100, count=12, size=(640, 360)):
    """Two 'cameras' from the real walking video: the clip and its mirror image."""
    video = share_path("testdata", "sports2d-demo.mp4")
    if not video.is_file():
        pytest.skip("test video not installed (run deploy/bootstrap.sh)")
    cap = cv2.VideoCapture(str(video))
    cap.set(cv2.CAP_PROP_POS_FRAMES, first)
    writers = {name: cv2.VideoWriter(str(folder / f"{name}.avi"), cv2.VideoWriter_fourcc(*"MJPG"), 30, size)
               for name in ("side", "mirror")}
    for _ in range(count):
        ok, frame = cap.read()
        assert ok
        small = cv2.resize(frame, size, interpolation=cv2.INTER_AREA)
        writers["side"].write(small)
        writers["mirror"].write(np.ascontiguousarray(small[:, ::-1]))
    for w in writers.values():
        w.release()


def test_detect_mediapipe_on_real_video(tmp_path):
    from gaitcap.acquisition.detectors.mediapipe import default_model_dir

    if not (default_model_dir() / "pose_landmark_lite.tflite").is_file():
        pytest.skip("MediaPipe models not installed (run deploy/bootstrap.sh)")
    vids = tmp_path / "vids"
    vids.mkdir()
    _demo_clips(vids)
    out = tmp_path / "kp.npz"
    lite = default_model_dir() / "pose_landmark_lite.tflite"
    res = CliRunner().invoke(app, ["detect", "--videos", str(vids), "--detector", "mediapipe", "--model", str(lite),
                                   "--out", str(out), "--one-per-camera"])
    assert res.exit_code == 0, res.output
    det = _one_person(out)
    assert det.camera_names == ("mirror", "side") and det.shape == (2, 12, 1, 33)
    assert det.skeleton.name == "mediapipe33"
    np.testing.assert_allclose(det.times_s, np.arange(12) / 30)
    j = det.skeleton.index
    hips = (det.one_person[:, :, j("left_hip"), :2] + det.one_person[:, :, j("right_hip"), :2]) / 2  # (C, T, 2)
    assert np.isfinite(hips).all()
    # The mirror view sees the walker at x' = W - x (pixel centres: 639 - x), same height.
    np.testing.assert_allclose(hips[0, :, 0], 639 - hips[1, :, 0], atol=8)
    np.testing.assert_allclose(hips[0, :, 1], hips[1, :, 1], atol=8)


def test_detect_onnx_model_by_path(tmp_path):
    import onnx
    from onnx import TensorProto, helper

    # A 17-joint SimCC model that puts every joint at the crop's brightest column / row.
    h, w = 64, 48
    nodes = [
        helper.make_node("ReduceSum", ["input", "a1"], ["g"], keepdims=1),
        helper.make_node("ReduceMax", ["g", "a2"], ["cm"], keepdims=0),  # (N,1,W)
        helper.make_node("ReduceMax", ["g", "a3"], ["rm"], keepdims=0),  # (N,1,H)
        helper.make_node("Expand", ["cm", "ex"], ["simcc_x"]),
        helper.make_node("Expand", ["rm", "ey"], ["simcc_y"]),
    ]
    i64 = lambda n, v: helper.make_tensor(n, TensorProto.INT64, [len(v)], v)  # noqa: E731
    inits = [i64("a1", [1]), i64("a2", [2]), i64("a3", [3]), i64("ex", [1, 17, w]), i64("ey", [1, 17, h])]
    graph = helper.make_graph(
        nodes, "g", [helper.make_tensor_value_info("input", TensorProto.FLOAT, ["N", 3, h, w])],
        [helper.make_tensor_value_info("simcc_x", TensorProto.FLOAT, ["N", 17, w]),
         helper.make_tensor_value_info("simcc_y", TensorProto.FLOAT, ["N", 17, h])], initializer=inits)
    model = tmp_path / "blob.onnx"
    onnx.save(helper.make_model(graph, opset_imports=[helper.make_opsetid("", 18)], ir_version=9), str(model))
    vids = tmp_path / "vids"
    vids.mkdir()
    _video(vids / "cam0.avi", 6, 30, 0)
    out = tmp_path / "kp.npz"
    res = CliRunner().invoke(app, ["detect", "--videos", str(vids), "--detector", "onnx", "--model", str(model),
                                   "--out", str(out)])
    assert res.exit_code == 0, res.output
    det = _one_person(out)
    assert det.skeleton.name == "coco17" and det.shape == (1, 6, 1, 17)
    # Whole 64x48 image as the box, padded 1.25: one crop px is 80 / 48 image px. The flat square's first
    # brightest crop column / row lies inside the square (give or take one crop px).
    crop_px = 80 / 48
    left = 4 + 2 * np.arange(6)
    x, y = det.one_person[0, :, :, 0], det.one_person[0, :, :, 1]
    assert np.all((x >= left[:, None] - crop_px) & (x <= left[:, None] + SQ - 1 + crop_px))
    assert np.all((y >= 20 - crop_px) & (y <= 20 + SQ - 1 + crop_px))
    assert 6 <= x[-1, 0] - x[0, 0] <= 14  # it follows the square 10 px to the right


def test_the_completion_detects_every_recorded_frame_unless_told_only_the_missing():
    from gaitcap.services.cli.detect import completion_plan

    assert completion_plan("none", None, [], None) is None
    every = completion_plan("mediapipe", None, ["model=lite"], 2)
    assert every.redetect_all and every.workers == 2 and every.detector.model == "lite"
    assert not completion_plan("mediapipe", None, [], None, only_missing=True).redetect_all
