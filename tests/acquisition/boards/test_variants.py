"""ChArUco boards as people print them (inverted, legacy layout, two-sided), found without being told
and named; the marker-to-square ratio measured from the markers; diagnosis that names the real cause."""

import cv2
import numpy as np
import pytest
from gaitcap.acquisition.boards.detection import BoardConfig, make_board
from gaitcap.acquisition.boards.diagnosis import CameraDetection, too_few_views_error

BOARD = dict(kind="charuco", squares_x=4, squares_y=6, square_mm=54.0, marker_mm=40.5, dictionary="DICT_4X4_1000")


def photo(config: BoardConfig, *, px_per_mm: float = 2.0, mirror: bool = False, seed: int = 0) -> np.ndarray:
    """The printed board seen at an angle, slightly blurred and noisy (as a webcam would)."""
    tex, _ = make_board(config).texture(px_per_mm)
    h, w = tex.shape
    src = np.float32([[0, 0], [w, 0], [w, h], [0, h]])
    dst = np.float32([[60, 40], [w + 30, 90], [w - 10, h + 70], [30, h + 20]])
    img = cv2.warpPerspective(tex, cv2.getPerspectiveTransform(src, dst), (w + 120, h + 140), borderValue=128)
    img = cv2.GaussianBlur(img, (0, 0), 1.0)
    img = np.clip(img + np.random.default_rng(seed).normal(0, 4, img.shape), 0, 255).astype(np.uint8)
    return cv2.flip(img, 1) if mirror else img


@pytest.mark.parametrize(("inverted", "legacy", "mirror", "name"), [
    (False, False, False, "normal"),
    (True, False, False, "inverted"),
    (False, True, False, "legacy layout"),
    (True, True, False, "inverted, legacy layout"),
    (False, False, True, "back side"),
])
def test_printing_variants_are_found_and_named(inverted, legacy, mirror, name):
    printed = BoardConfig(**BOARD, inverted=inverted, legacy_layout=legacy)
    img = photo(printed, mirror=mirror)
    found = make_board(BoardConfig(**BOARD)).find(img)  # told nothing about how it was printed
    assert found.variant is not None and found.variant.describe() == name
    assert found.n_corners == 15  # all inner corners of 4 x 6 squares
    # the corners are where the plain detector finds them on the plain image
    plain = make_board(BoardConfig(**BOARD, inverted=False, legacy_layout=legacy)).detect(
        photo(BoardConfig(**BOARD, legacy_layout=legacy)))
    if not mirror:
        assert np.nanmax(np.abs(found.corners - plain)) < 0.5
    else:  # a mirror image: back on the camera's pixels, the corners lie where the mirrored board put them
        flipped = plain.copy()
        flipped[:, 0] = img.shape[1] - 1 - plain[:, 0]
        assert np.nanmax(np.abs(found.corners - flipped)) < 0.5


def test_a_fixed_variant_is_the_only_one_tried():
    img = photo(BoardConfig(**BOARD, inverted=True))
    assert make_board(BoardConfig(**BOARD, inverted=False)).find(img).corners is None
    assert make_board(BoardConfig(**BOARD, inverted=True)).find(img).n_corners == 15


def test_odd_row_boards_have_one_layout():
    board = make_board(BoardConfig(**{**BOARD, "squares_y": 5}))
    assert {v.legacy for v in board.variants} == {False}


def test_marker_ratio_is_measured_from_the_markers():
    img = photo(BoardConfig(**BOARD))
    right = make_board(BoardConfig(**BOARD)).find(img)
    wrong = make_board(BoardConfig(**{**BOARD, "marker_mm": 27.0})).find(img)
    assert abs(right.marker_ratio - 0.75) < 0.02
    assert abs(wrong.marker_ratio - 0.75) < 0.02  # measured, whatever the description says
    assert 25 < right.marker_px < 100


def _stats(config: BoardConfig, images: list[np.ndarray]) -> CameraDetection:
    board = make_board(config)
    return CameraDetection.from_finds("cam01", [board.find(i) for i in images], min_corners=6)


def test_diagnosis_blames_the_sizes_only_when_the_ratio_disagrees():
    said = BoardConfig(**{**BOARD, "marker_mm": 27.0})
    stats = _stats(said, [photo(BoardConfig(**BOARD), seed=s) for s in range(2)])
    err = str(too_few_views_error((stats,), said, min_views=6))
    assert "markers measure 0.75 of a square" in err and "says 0.50" in err
    right = BoardConfig(**BOARD)
    err = str(too_few_views_error((_stats(right, [photo(right, seed=s) for s in range(2)]),), right, min_views=6))
    assert "camera 'cam01'" in err and "2 usable views, need 6" in err
    assert "size" not in err


def test_diagnosis_without_markers_names_the_dictionary_and_small_markers():
    blank = np.full((240, 320), 128, np.uint8)
    config = BoardConfig(**BOARD)
    err = str(too_few_views_error((_stats(config, [blank] * 3),), config, min_views=6))
    assert "no DICT_4X4_1000 marker in any of 3 frames (normal and inverted tried)" in err
    far = CameraDetection("cam02", frames=50, with_markers=40, with_board=3, marker_px=11.0, marker_ratio=0.74)
    tips = " ".join(far.advice(config, 6))
    assert "markers are only 11 px across" in tips and "bring the board closer" in tips
    assert "enough corners in only 3" in tips and "size" not in tips


def test_views_smeared_by_the_readout_do_not_count_for_the_intrinsics():
    config = BoardConfig.checkerboard()
    cam = CameraDetection("cam01", frames=30, with_markers=0, with_board=20, marker_px=float("nan"),
                          marker_ratio=float("nan"), moving=4, smeared=8)
    assert cam.usable() == 12  # moving views still serve the intrinsics; smeared ones were left out
    err = str(too_few_views_error((cam,), config, min_views=15))
    assert "12 usable views, need 15" in err and "8 views left out because the board moved during" in err


def test_a_fixed_variant_that_finds_nothing_is_probed():
    from gaitcap.acquisition.boards.recording import _detect

    said = BoardConfig(**BOARD, inverted=False)
    frames = iter([(0, i, photo(BoardConfig(**BOARD, inverted=True), seed=i)) for i in range(2)])
    finds, _, probes = _detect(frames, said, 1, None)
    assert all(f.corners is None for f in finds.values())
    stats = CameraDetection.from_finds("cam01", list(finds.values()), min_corners=6, probe=probes.get(0))
    assert "found the board as inverted (2 frames)" in " ".join(stats.advice(said, 6))


def test_an_inverted_checkerboard_is_found_too():
    board = make_board(BoardConfig.checkerboard(7, 5, 30.0))
    tex, _ = board.texture(3.0)
    inverted = cv2.copyMakeBorder(255 - tex, 40, 40, 40, 40, cv2.BORDER_CONSTANT, value=0)
    assert board.detect(inverted).shape == (24, 2)  # the checkerboard search is colour-blind


def test_the_issues_recording_webcam_videos_of_an_inverted_board(tmp_path):
    """The issue's case: videos of a 4 x 5 inverted DICT_4X4_1000 board, described without --inverted
    (the second camera's video one frame shorter), paired by the containers' frame times."""
    from gaitcap.acquisition.boards.recording import find_board_views

    printed = BoardConfig("charuco", 4, 5, 54.0, 40.5, "DICT_4X4_1000", inverted=True)
    for cam, n in (("cam_a", 6), ("cam_b", 5)):
        frames = [photo(printed, seed=s) for s in range(n)]
        h, w = frames[0].shape
        video = cv2.VideoWriter(str(tmp_path / f"{cam}.mp4"), cv2.VideoWriter_fourcc(*"mp4v"), 10.0, (w, h))
        assert video.isOpened()
        for f in frames:
            video.write(cv2.cvtColor(f, cv2.COLOR_GRAY2BGR))
        video.release()
    said = BoardConfig("charuco", 4, 5, 54.0, 40.5, "DICT_4X4_1000")
    found = find_board_views(tmp_path, board=said)
    assert found.timed  # frame times from the containers
    assert [c.with_board for c in found.cameras] == [6, 5]
    assert all(c.variants == {"inverted": c.with_board} for c in found.cameras)
    assert found.observations.views().sum(1).tolist() == [6, 5] and found.observations.shape[1] == 6
