import cv2
import numpy as np
import pytest
from gaitcap.acquisition.board import BoardConfig, make_board

PX_PER_MM = 1.0


def _framed(board):
    img, corner0 = board.texture(PX_PER_MM)
    pad = 40
    return cv2.copyMakeBorder(img, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=120), corner0 + pad


def test_checkerboard_corners_found_up_to_its_symmetry():
    board = make_board(BoardConfig.checkerboard())
    assert board.geometry.num_corners == 24 and board.pattern == (6, 4)
    img, corner0 = _framed(board)
    found = board.detect(img)
    expected = corner0 + board.geometry.object_points_mm[:, :2] * PX_PER_MM
    errors = [np.abs(found - expected[list(p)]).max() for p in board.geometry.symmetries]
    assert min(errors) < 0.3
    rotated = board.detect(cv2.rotate(img, cv2.ROTATE_180))
    assert rotated is not None and len(rotated) == 24


def test_charuco_ids_fix_the_order_even_when_turned():
    board = make_board(BoardConfig.charuco())
    assert len(board.geometry.symmetries) == 1
    img, corner0 = _framed(board)
    expected = corner0 + board.geometry.object_points_mm[:, :2] * PX_PER_MM
    assert np.abs(board.detect(img) - expected).max() < 0.3
    h, w = img.shape
    turned = board.detect(cv2.rotate(img, cv2.ROTATE_180))
    assert np.abs(turned - ([w - 1, h - 1] - expected)).max() < 0.3
    half = img.copy()
    half[:, w // 2:] = 120  # half the board hidden: the visible corners still come with their ids
    partial = board.detect(half)
    seen = np.isfinite(partial[:, 0])
    assert 6 <= seen.sum() < 24 and np.abs(partial[seen] - expected[seen]).max() < 0.3


def test_no_board_no_corners():
    for cfg in (BoardConfig.checkerboard(), BoardConfig.charuco()):
        assert make_board(cfg).detect(np.full((200, 300), 128, np.uint8)) is None


def test_bad_board_definitions_are_named():
    with pytest.raises(ValueError, match="board kind 'circles' is unknown"):
        make_board(BoardConfig(kind="circles"))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="unknown ArUco dictionary 'DICT_NOPE'"):
        make_board(BoardConfig.charuco(dictionary="DICT_NOPE"))
    with pytest.raises(ValueError, match="square corner grid"):
        make_board(BoardConfig.checkerboard(5, 5))
