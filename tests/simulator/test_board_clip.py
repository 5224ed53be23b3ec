"""A simulated calibration recording is a real trial MCAP with every camera's frames, and nothing is left
behind when writing it fails."""

import cv2
import numpy as np
import pytest
from gaitcap.acquisition.recording.reader import iter_frames
from gaitcap.simulator.board_clip import BoardClipConfig, write_board_clip

SMALL = BoardClipConfig(frames=12, floor_frames=2, cameras=3, scale=0.2)


def test_writes_every_camera_frame(tmp_path):
    done = []
    path, truth = write_board_clip(tmp_path / "board.mcap", SMALL, progress=lambda i, n: done.append((i, n)))
    frames = list(iter_frames(path))
    assert len(frames) == 12 * 3 and done[-1] == (12, 12)
    assert sorted({f.camera for f in frames}) == ["cam01", "cam02", "cam03"] == truth.names
    img = cv2.imdecode(np.frombuffer(frames[0].jpeg, np.uint8), cv2.IMREAD_GRAYSCALE)
    assert (img.shape[1], img.shape[0]) == truth[0].size_px == (384, 240)
    first = [f for f in frames if f.frame_id == 0]
    assert len(first) == 3 and len({f.timestamp_ns for f in first}) == 1  # synchronised


def test_a_failure_leaves_no_file(tmp_path):
    def stop(i, n):
        if i == 3:
            raise RuntimeError("disk full")

    with pytest.raises(RuntimeError, match="disk full"):
        write_board_clip(tmp_path / "board.mcap", SMALL, progress=stop)
    assert list(tmp_path.iterdir()) == []


def test_bad_config_is_named():
    with pytest.raises(ValueError, match="frames"):
        BoardClipConfig(frames=20, floor_frames=10)
    with pytest.raises(ValueError, match="scale"):
        BoardClipConfig(scale=2.0)
