"""A given calibration measured on board corners (the board poses fitted with the rig held): the true rig
explains corners with 0.3 px noise per axis at the noise (2D RMS 0.42 px) on every camera, also when the
detector reports a checkerboard's corners in a symmetric order; a camera turned by 0.5 deg stands out."""

import numpy as np
import pytest
from gaitcap.acquisition.boards.detection import BoardConfig, make_board
from gaitcap.reconstruction.calibration.refit import fit_board_to_rig
from gaitcap.reconstruction.camera import Rig, matrix_to_rodrigues
from gaitcap.simulator.board import BoardMotion, board_trajectory, observe_board
from gaitcap.simulator.room import build_rig

NOISE_PX = 0.3


@pytest.fixture(scope="module")
def room():
    rig = build_rig(10, seed=0).subset(["cam01", "cam02", "cam03", "cam04"])
    board = make_board(BoardConfig.checkerboard())
    rot, tvec = board_trajectory(board.geometry, BoardMotion(n_frames=120, floor_frames=5, seed=1), rig)
    return rig, observe_board(rig, board.geometry, rot, tvec, noise_px=NOISE_PX, scramble=True, seed=2)


def test_the_true_rig_explains_the_corners_at_the_noise(room):
    rig, obs = room
    fit = fit_board_to_rig(obs, rig)
    assert fit.cameras == ("cam01", "cam02", "cam03", "cam04")
    assert fit.views == tuple(int(n) for n in obs.views().sum(1))  # every view used (the right symmetry found)
    expected = NOISE_PX * np.sqrt(2)
    for name, rms, rms_all in zip(fit.cameras, fit.rms_px, fit.rms_all_px, strict=True):
        assert 0.8 * expected < rms < 1.1 * expected, (name, rms)
        assert rms <= rms_all < 1.2 * expected, (name, rms_all)


def test_a_turned_camera_stands_out(room):
    rig, obs = room
    turn = np.deg2rad(0.5)
    spin = np.array([[np.cos(turn), -np.sin(turn), 0], [np.sin(turn), np.cos(turn), 0], [0, 0, 1]])
    cam = rig["cam03"]
    turned = Rig(tuple(c if c.name != "cam03" else type(c)(c.name, c.size_px, c.matrix_px, c.dist,
                                                            matrix_to_rodrigues(spin @ cam.rotation), c.tvec_mm)
                       for c in rig.cameras))
    fit = fit_board_to_rig(obs, turned)
    worst = int(np.argmax(fit.rms_all_px))
    assert fit.cameras[worst] == "cam03" and fit.rms_all_px[worst] > 3 * max(np.delete(fit.rms_all_px, worst))
