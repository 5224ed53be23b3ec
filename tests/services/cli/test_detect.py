"""`gaitcap detect --videos DIR`: a detector defined here finds a bright square in each camera's video."""

from dataclasses import dataclass

import cv2
import numpy as np
import pytest
from typer.testing import CliRunner

from acquisition.detectors.base import DETECTOR_CONFIGS, DetectorConfig
from acquisition.video_detect import detect_videos, find_videos
from reconstruction.association.npz_io import load_detections_npz, load_multi_npz
from reconstruction.skeletons import get_skeleton
from services.cli import app

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
    out, multi = tmp_path / "kp.npz", tmp_path / "all.npz"
    res = CliRunner().invoke(app, ["detect", "--videos", str(vids), "--detector", "test-blob", "--model", "x.onnx",
                                   "--out", str(out), "--all-people", str(multi)])
    assert res.exit_code == 0, res.output
    det = load_detections_npz(out)
    assert det.camera_names == ("left", "right") and det.shape == (2, 12, 17)
    np.testing.assert_allclose(np.diff(det.times_s), 1 / 30, rtol=1e-6)
    np.testing.assert_allclose(det.keypoints[0, :, 0, 0], 4 + 2 * np.arange(12) + (SQ - 1) / 2, atol=0.6)
    np.testing.assert_allclose(det.keypoints[0, :, 0, 2], 0.9)  # the confident person, odd frames too
    assert (det.keypoints[1, 10:, :, 2] == 0).all()  # the shorter file is padded as missing
    assert load_multi_npz(multi).keypoints.shape == (2, 12, 2, 17, 3)


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
    assert detect_videos(find_videos(tmp_path), BlobDetector(), fps=30).fps == 30
