import cv2
import numpy as np
import pytest
from gaitcap.acquisition.boards.detection import BoardConfig, make_board

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


@pytest.mark.parametrize("px_per_mm", [0.025, 0.03, 0.04])
def test_a_small_image_with_squares_of_3_to_4_px_is_searched_enlarged(px_per_mm):
    """The demo's 240 x 180 px cameras see the 110 mm squares 2-5 px wide: findChessboardCornersSB misses
    such a board as it is but finds it enlarged; the corners come back in the image's own pixels."""
    board = make_board(BoardConfig.checkerboard())
    img, corner0 = board.texture(1.0)
    small = cv2.resize(img, None, fx=px_per_mm, fy=px_per_mm, interpolation=cv2.INTER_AREA)
    frame = np.full((180, 240), 120, np.uint8)
    frame[60:60 + small.shape[0], 70:70 + small.shape[1]] = small
    assert board._find(frame) is None  # as it is: not found
    found = board.detect(frame)
    expected = (corner0 + board.geometry.object_points_mm[:, :2] + 0.5) * px_per_mm - 0.5 + [70, 60]
    assert found is not None
    assert min(np.abs(found - expected[list(p)]).max() for p in board.geometry.symmetries) < 0.25
