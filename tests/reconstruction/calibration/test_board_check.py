"""The board measured in 3D with a calibration (synthetic room, 3 cameras, the true rig): the squares come
back at the size described and the board flat; a print scaled 3 % along its columns is named; a board
described with the wrong square size is named when a calibration made with the true size measures it."""

from dataclasses import replace

import numpy as np
import pytest
from gaitcap.acquisition.boards.detection import BoardConfig, make_board
from gaitcap.reconstruction.calibration.board_check import check_board, size_problem
from gaitcap.simulator.board import BoardMotion, board_trajectory, observe_board
from gaitcap.simulator.room import build_rig


@pytest.fixture(scope="module")
def room():
    rig = build_rig(10, seed=0).subset(["cam01", "cam02", "cam03"])
    board = make_board(BoardConfig.checkerboard()).geometry
    rot, tvec = board_trajectory(board, BoardMotion(n_frames=60, floor_frames=2, seed=1), rig)
    return rig, board, rot, tvec


def _check(rig, board, obs, described=None):
    extr = np.stack([np.concatenate([c.rotation, c.tvec_mm[:, None]], 1) for c in rig])
    return check_board(obs.corners_px, np.stack([c.matrix_px for c in rig]), np.stack([c.dist for c in rig]), extr,
                       described or board, tuple(rig.names))


def test_the_true_rig_measures_the_board_as_described(room):
    rig, board, rot, tvec = room
    obs = observe_board(rig, board, rot, tvec, noise_px=0.0)
    check = _check(rig, board, obs)
    assert check.frames > 10 and check.points > 100
    assert abs(check.square_mm - 110.0) < 0.01 and check.flatness_rms_mm < 0.01 and check.shape_rms_mm < 0.01
    assert size_problem(check) is None
    noisy = _check(rig, board, observe_board(rig, board, rot, tvec, noise_px=0.5, seed=3))
    assert abs(noisy.square_residual_pct) < 0.3 and 0.05 < noisy.flatness_rms_mm < 3.0
    assert size_problem(noisy) is None


def test_a_print_scaled_along_its_columns_is_named(room):
    rig, board, rot, tvec = room
    stretched = replace(board, object_points_mm=board.object_points_mm * [1.03, 1.0, 1.0])
    obs = observe_board(rig, stretched, rot, tvec, noise_px=0.0)
    check = _check(rig, board, obs)
    assert abs(check.square_cols_mm - 113.3) < 0.05 and abs(check.square_rows_mm - 110.0) < 0.05
    problem = size_problem(check)
    assert problem.startswith("board shape mismatch: triangulated with this calibration its squares measure "
                              "113.30 mm along the columns and 110.00 mm along the rows (+3.0 %)"), problem


def test_a_board_described_with_the_wrong_square_size_is_named(room):
    rig, board, rot, tvec = room
    obs = observe_board(rig, board, rot, tvec, noise_px=0.0)
    described = replace(board, square_mm=100.0)  # the user typed 100 mm for the 110 mm board
    problem = size_problem(_check(rig, board, obs, described), who="the reference calibration")
    assert problem.startswith("board size mismatch: triangulated with the reference calibration its squares "
                              "measure 110.00 mm, described as 100 mm (+10.0 %)"), problem
