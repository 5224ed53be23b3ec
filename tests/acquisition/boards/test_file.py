"""Board files: gaitcap's own (TOML and JSON), caliscope's charuco.toml, anipose's and Pose2Sim's configs."""

import json

import pytest
from gaitcap.acquisition.boards.detection import BoardConfig
from gaitcap.acquisition.boards.file import board_to_toml, read_board_file
from gaitcap.acquisition.installed import share_path

REAL = share_path("testdata", "calibration")


def test_own_format_round_trips_in_toml_and_json(tmp_path):
    board = BoardConfig("charuco", 4, 5, 54.0, 40.5, "DICT_4X4_1000", inverted=True)
    (tmp_path / "b.toml").write_text(board_to_toml(board))
    assert read_board_file(tmp_path / "b.toml") == board
    (tmp_path / "b.json").write_text(json.dumps({"board": {"kind": "checkerboard", "squares": [7, 5],
                                                           "square_mm": 110}}))
    assert read_board_file(tmp_path / "b.json") == BoardConfig.checkerboard()


def test_caliscope_board_without_a_square_override(tmp_path):
    (tmp_path / "charuco.toml").write_text('columns = 4\nrows = 5\nboard_height = 11.0\nboard_width = 8.5\n'
                                           'dictionary = "DICT_4X4_50"\nunits = "inch"\naruco_scale = 0.75\n')
    board = read_board_file(tmp_path / "charuco.toml")
    assert board.kind == "charuco" and (board.squares_x, board.squares_y) == (4, 5)
    assert board.square_mm == pytest.approx(8.5 / 4 * 25.4)  # the width limits: 4 squares in 8.5 inch
    assert board.marker_mm == pytest.approx(0.75 * board.square_mm) and board.inverted is False


def test_anipose_config(tmp_path):
    (tmp_path / "config.toml").write_text(
        '[calibration]\nboard_type = "charuco"\nboard_size = [10, 7]\nboard_marker_bits = 5\n'
        'board_marker_dict_number = 100\nboard_marker_length = 18.75\nboard_square_side_length = 25\n')
    assert read_board_file(tmp_path / "config.toml") == BoardConfig("charuco", 10, 7, 25.0, 18.75, "DICT_5X5_100")
    (tmp_path / "config.toml").write_text('[calibration]\nboard_type = "checkerboard"\nboard_size = [9, 6]\n'
                                          'board_square_side_length = 30\n')
    assert read_board_file(tmp_path / "config.toml") == BoardConfig.checkerboard(10, 7, 30.0)  # inner corners


@pytest.mark.skipif(not (REAL / "pose2sim-single" / "Config.toml").exists(), reason="Pose2Sim demo not installed")
def test_pose2sim_config_and_caliscope_board_as_shipped():
    assert read_board_file(REAL / "pose2sim-single" / "Config.toml") == BoardConfig.checkerboard(8, 5, 60.0)
    board = read_board_file(REAL / "caliscope-4cam" / "charuco.toml")
    assert board == BoardConfig("charuco", 4, 5, 54.0, 40.5, "DICT_4X4_1000", inverted=True, legacy_layout=False)


def test_bad_board_files_name_the_problem(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        read_board_file(tmp_path / "none.toml")
    (tmp_path / "a.toml").write_text('[board]\nkind = "charuco"\nsquares = [4]\nsquare_mm = 54\n')
    with pytest.raises(ValueError, match="field 'squares' must be two whole numbers"):
        read_board_file(tmp_path / "a.toml")
    (tmp_path / "b.toml").write_text('[board]\nkind = "charuco"\nsquares = [4, 5]\nsquare_mm = 54\n'
                                     'dictionary = "DICT_9X9_1"\n')
    with pytest.raises(ValueError, match="unknown ArUco dictionary 'DICT_9X9_1'"):
        read_board_file(tmp_path / "b.toml")
    (tmp_path / "c.toml").write_text('title = "not a board"\n')
    with pytest.raises(ValueError, match="not a board file"):
        read_board_file(tmp_path / "c.toml")
    (tmp_path / "d.json").write_text("{")
    with pytest.raises(ValueError, match="not valid JSON"):
        read_board_file(tmp_path / "d.json")
