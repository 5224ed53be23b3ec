"""Still board runs are merged into one frame each, also with real detector behaviour (missed views,
corner order flipped between frames of a still board)."""

import numpy as np
from gaitcap.reconstruction.calibration.geometry import BoardObservations, grid_board
from gaitcap.reconstruction.calibration.still import align_view, merge_still_frames


def _board(mirror: bool):
    return grid_board("b", corners_x=3, corners_y=2, square_mm=50.0, mirror_ambiguous=mirror, min_corners=6)


def test_still_run_then_moving_board():
    b = _board(False)
    rng = np.random.default_rng(0)
    base = rng.uniform(0, 600, (2, 1, 6, 2))
    still = base + rng.normal(0, 0.05, (2, 4, 6, 2))  # four frames of a still board
    moving = base + np.arange(1, 4)[None, :, None, None] * 20.0  # then it moves
    corners = np.concatenate([still, moving], axis=1)
    corners[1, 5] = np.nan  # camera 1 loses it in one frame
    obs = BoardObservations(("a", "c"), ((640, 480),) * 2, corners, b)
    merged, starts = merge_still_frames(obs)
    assert starts.tolist() == [0, 4, 5, 6]
    assert np.allclose(merged.corners_px[:, 0], still.mean(1))
    assert np.isnan(merged.corners_px[1, 2]).all() and np.allclose(merged.corners_px[0, 2], corners[0, 5])


def test_missed_views_and_flipped_order_do_not_split_a_still_run():
    b = _board(True)
    syms = np.asarray(b.symmetries)
    rng = np.random.default_rng(1)
    base = rng.uniform(0, 600, (3, 1, 6, 2))
    corners = base + rng.normal(0, 0.05, (3, 6, 6, 2))
    truth_mean = corners.mean(1)
    corners[0, 2] = np.nan  # camera 0 misses the board once
    corners[1, 3] = corners[1, 3][syms[1]]  # camera 1 reports it turned by 180 degrees once
    corners[2, :2] = np.nan  # camera 2 sees it only from frame 2 on
    obs = BoardObservations(("a", "b", "c"), ((640, 480),) * 3, corners, b)
    merged, starts = merge_still_frames(obs)
    assert starts.tolist() == [0]
    keep = [0, 1, 3, 4, 5]
    assert np.allclose(merged.corners_px[0, 0], base[0, 0] + (corners[0, keep] - base[0]).mean(0))
    assert np.allclose(merged.corners_px[1, 0], truth_mean[1], atol=1e-9)
    assert np.allclose(merged.corners_px[2, 0], corners[2, 2:].mean(0))


def test_a_board_that_moves_in_one_camera_ends_the_run():
    b = _board(False)
    base = np.random.default_rng(2).uniform(0, 600, (2, 1, 6, 2))
    corners = np.repeat(base, 4, axis=1)
    corners[1, 2:] += 3.0  # camera 1 sees it move (camera 0 does not: e.g. along its line of sight)
    obs = BoardObservations(("a", "b"), ((640, 480),) * 2, corners, b)
    _, starts = merge_still_frames(obs)
    assert starts.tolist() == [0, 2]


def test_align_view_needs_shared_corners():
    b = _board(False)
    syms = np.asarray(b.symmetries)
    ref = np.random.default_rng(3).uniform(0, 600, (6, 2))
    view = ref.copy()
    view[:3] = np.nan
    assert align_view(view, ref, syms, 0.5) is None  # 3 shared corners cannot prove stillness
    view = ref + 0.1
    assert np.allclose(align_view(view, ref, syms, 0.5), view)
    assert align_view(ref + 1.0, ref, syms, 0.5) is None


def test_one_jittering_corner_does_not_end_the_run():
    b = _board(False)
    base = np.random.default_rng(4).uniform(0, 600, (1, 1, 6, 2))
    corners = np.repeat(base, 3, axis=1)
    corners[0, 1, 2] += 2.5  # the detector misplaces one corner in one frame
    obs = BoardObservations(("a",), ((640, 480),), corners, b)
    merged, starts = merge_still_frames(obs)
    assert starts.tolist() == [0]
    assert np.isclose(merged.corners_px[0, 0, 2, 0], base[0, 0, 2, 0] + 2.5 / 3)
