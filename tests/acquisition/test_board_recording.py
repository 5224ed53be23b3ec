"""Board observations from a recorded MCAP and from a folder of images: the same corners either way."""

import numpy as np
import pytest
from gaitcap.acquisition.board import BoardConfig, make_board
from gaitcap.acquisition.board_recording import FrameSelection, detect_recording
from gaitcap.acquisition.synthetic.board import (
    BoardMotion,
    board_trajectory,
    render_board_images,
    write_board_folder,
    write_board_mcap,
)
from gaitcap.acquisition.synthetic.room import build_rig


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    root = tmp_path_factory.mktemp("board")
    rig = build_rig(10, seed=0).subset(["cam01", "cam02"])
    board = make_board(BoardConfig.checkerboard())
    rot, tvec = board_trajectory(board.geometry, BoardMotion(n_frames=40, floor_frames=3, seed=3), rig)
    images = render_board_images(rig, board, rot[::4], tvec[::4], scale=0.3)
    return write_board_folder(root / "folder", images), write_board_mcap(root / "board.mcap", images, fps=10.0)


def test_mcap_and_folder_give_the_same_observations(recordings):
    folder, mcap = recordings
    a = detect_recording(folder, board=BoardConfig.checkerboard())
    b = detect_recording(mcap, board=BoardConfig.checkerboard())
    assert a.camera_names == b.camera_names == ("cam01", "cam02")
    assert a.image_sizes_px == ((576, 360), (576, 360))
    assert a.views().sum() >= 8
    assert np.array_equal(a.views(), b.views())
    both = np.isfinite(a.corners_px) & np.isfinite(b.corners_px)
    assert np.abs(a.corners_px - b.corners_px)[both].max() < 1.0  # PNG vs JPEG at quality 95
    assert np.allclose(b.times_s * 10, np.round(b.times_s * 10)) and b.times_s[0] == 0  # recorder clock at 10 Hz, s


def test_frame_selection(recordings):
    folder, _ = recordings
    obs = detect_recording(folder, board=BoardConfig.checkerboard(), selection=FrameSelection(every=3, max_frames=2))
    assert set(obs.times_s.tolist()) <= {0.0, 3.0}


def test_bad_recordings_are_named(tmp_path, recordings):
    with pytest.raises(ValueError, match="does not exist"):
        detect_recording(tmp_path / "nope.mcap")
    with pytest.raises(ValueError, match="no camera images or videos"):
        detect_recording(tmp_path)
    with pytest.raises(ValueError, match="every"):
        FrameSelection(every=0)
