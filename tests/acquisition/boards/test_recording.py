"""Board observations from a recorded MCAP and from a folder of images: the same corners either way."""

import numpy as np
import pytest
from gaitcap.acquisition.boards.detection import BoardConfig, make_board
from gaitcap.acquisition.boards.recording import FrameSelection, detect_recording
from gaitcap.simulator.board import (
    BoardMotion,
    board_trajectory,
    render_board_images,
    write_board_folder,
    write_board_mcap,
)
from gaitcap.simulator.room import build_rig


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


def _stamps(folder, offsets_ms: dict[str, float], period_ms: float = 100.0) -> None:
    lines = ["camera,frame,time_s"]
    for cam, offset in offsets_ms.items():
        for i, _ in enumerate(sorted((folder / cam).iterdir())):
            lines.append(f"{cam},{i},{1000.5 + (i * period_ms + offset) / 1000:.6f}")
    (folder / "timestamps.csv").write_text("\n".join(lines) + "\n")


@pytest.fixture(scope="module")
def truth(recordings):
    return detect_recording(recordings[0], board=BoardConfig.checkerboard())


def test_frames_are_paired_by_time_not_by_order(recordings, truth, tmp_path):
    import shutil

    folder, _ = recordings
    late = shutil.copytree(folder, tmp_path / "late")
    (late / "cam02" / "000000.png").unlink()  # cam02 started one frame late: its image k is frame k + 1
    by_order = detect_recording(late, board=BoardConfig.checkerboard())
    assert not np.array_equal(by_order.views(), truth.views())
    _stamps(late, {"cam01": 0.0, "cam02": 100.0})
    by_time = detect_recording(late, board=BoardConfig.checkerboard())
    assert by_time.shape == truth.shape
    assert np.array_equal(by_time.views()[0], truth.views()[0])
    assert np.array_equal(by_time.views()[1, 1:], truth.views()[1, 1:]) and not by_time.views()[1, 0]
    both = np.isfinite(by_time.corners_px) & np.isfinite(truth.corners_px)
    assert both[1].any() and np.abs(by_time.corners_px - truth.corners_px)[both].max() < 1e-9
    assert np.allclose(by_time.times_s, truth.times_s * 0.1)  # s from the file (truth: frame indices)


def test_views_of_a_board_moving_between_exposures_are_left_out(recordings, truth, tmp_path):
    import shutil

    from gaitcap.acquisition.boards.pairing import PairingConfig
    from gaitcap.acquisition.boards.recording import find_board_views

    folder, _ = recordings
    copy = shutil.copytree(folder, tmp_path / "offset")
    _stamps(copy, {"cam01": 0.0, "cam02": 20.0})  # 20 ms apart while the board moves hundreds of px/s
    moved = find_board_views(copy, board=BoardConfig.checkerboard())
    n_moving = sum(c.moving for c in moved.cameras)
    assert all(c.moving > 0 for c in moved.cameras) and "moving" in moved.table()
    views = moved.observations.views()
    assert views.sum() == truth.views().sum()  # every view kept for the intrinsics ...
    assert views.shape[1] == truth.shape[1] + n_moving and (views.sum(0) == 1).sum() >= n_moving  # ... alone
    assert moved.timed and set(np.round(moved.observations.times_s, 6)) == set(np.round(truth.times_s * 0.1, 6))
    with pytest.raises(ValueError, match="max_shift_px"):
        PairingConfig(max_shift_px=0)


def test_timestamps_file_errors_name_the_problem(recordings, tmp_path):
    import shutil

    folder, _ = recordings
    copy = shutil.copytree(folder, tmp_path / "bad")
    (copy / "timestamps.csv").write_text("camera,when\ncam01,1.0\n")
    with pytest.raises(ValueError, match="needs a camera column"):
        detect_recording(copy)
    (copy / "timestamps.csv").write_text("camera,time_s\ncam09,1.0\n")
    with pytest.raises(ValueError, match="camera 'cam09' is none of"):
        detect_recording(copy)


def test_times_that_do_not_increase_fall_back_to_order(recordings, truth, tmp_path):
    import shutil

    copy = shutil.copytree(recordings[0], tmp_path / "flat")
    lines = ["camera,time_s"] + [f"{cam},5.0" for cam in ("cam01", "cam02") for _ in (copy / cam).iterdir()]
    (copy / "timestamps.csv").write_text("\n".join(lines) + "\n")
    obs = detect_recording(copy, board=BoardConfig.checkerboard(), selection=FrameSelection(max_frames=4))
    assert np.array_equal(obs.views(), truth.views()[:, : obs.shape[1]]) and obs.times_s.tolist() == [0, 1, 2, 3]


def test_options_that_need_frame_times_are_refused_on_frames_paired_by_order(recordings, tmp_path):
    import shutil

    from gaitcap.acquisition.boards.pairing import PairingConfig
    from gaitcap.acquisition.boards.recording import find_board_views

    folder, _ = recordings  # image folders without a timestamps.csv: paired by order
    untimed = r"carry no timestamps, so the cameras are paired by order"
    for pairing, words in ((PairingConfig(readout_ms=20.0), r"readout_ms 20 \(--readout-ms\) needs frame times"),
                           (PairingConfig(tolerance_ms=5.0), r"tolerance_ms 5 \(--sync-tolerance-ms\) needs frame times"),
                           (PairingConfig(max_shift_px=2.0), r"max_shift_px 2 needs frame times"),
                           (PairingConfig(tolerance_ms=5.0, readout_ms=20.0),
                            r"tolerance_ms 5 \(--sync-tolerance-ms\) and readout_ms 20 \(--readout-ms\) need frame times")):
        with pytest.raises(ValueError, match=f"folder: the frames of cameras .'cam01', 'cam02'. {untimed}.* {words}; "
                                             r"add \(or correct\) a timestamps.csv beside the camera folders"):
            find_board_views(folder, board=BoardConfig.checkerboard(), pairing=pairing)
    flat = shutil.copytree(folder, tmp_path / "flat")  # times that do not increase say nothing either
    lines = ["camera,time_s"] + [f"{cam},5.0" for cam in ("cam01", "cam02") for _ in (flat / cam).iterdir()]
    (flat / "timestamps.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(ValueError, match=r"frame times of cameras .'cam01', 'cam02'. do not increase.* readout_ms 20"):
        find_board_views(flat, board=BoardConfig.checkerboard(), pairing=PairingConfig(readout_ms=20.0))
    timed = shutil.copytree(folder, tmp_path / "timed")
    _stamps(timed, {"cam01": 0.0, "cam02": 0.0})
    found = find_board_views(timed, board=BoardConfig.checkerboard(), selection=FrameSelection(max_frames=3),
                             pairing=PairingConfig(tolerance_ms=5.0, readout_ms=20.0))
    assert found.timed and found.observations.shape[:2] == (2, 3)  # with times: applied


def test_views_smeared_during_the_readout_are_handed_to_the_calibration_as_views_found():
    """The views ``--readout-ms`` leaves out still count among a camera's views found, so a camera judged
    on less than half of them is refused (``calibrate_from_observations(views_removed=...)``)."""
    from gaitcap.acquisition.boards.diagnosis import CameraDetection
    from gaitcap.acquisition.boards.recording import BoardDetections

    cams = tuple(CameraDetection.from_finds(name, [], min_corners=4, smeared=k)
                 for name, k in (("cam01", 24), ("cam02", 0), ("cam03", 1)))
    found = BoardDetections(observations=None, cameras=cams, board=BoardConfig.checkerboard(), timed=True)
    assert found.views_removed == {"cam01": 24, "cam03": 1}
