"""Pairing unsynchronised cameras' frames by time, and the board speed that marks moving views."""

import numpy as np
from gaitcap.acquisition.boards.pairing import (
    MISSING,
    board_speed_px_s,
    default_tolerance_ns,
    moving_views,
    pair_by_time,
    smeared_views,
)

MS = 1_000_000  # ns


def test_jittered_offset_cameras_with_a_dropped_frame_pair_up():
    rng = np.random.default_rng(0)
    base = np.arange(20) * 33 * MS
    a = base + rng.integers(-2, 3, 20) * MS
    b = np.delete(base + 9 * MS + rng.integers(-2, 3, 20) * MS, 7)  # 9 ms late, frame 7 dropped
    tol = default_tolerance_ns([a, b])
    assert 15 * MS <= tol <= 17 * MS  # half a frame interval
    sets = pair_by_time([a, b], tol)
    assert len(sets) == 20
    assert sets[:, 0].tolist() == list(range(20))
    assert sets[7, 1] == MISSING and sets[8, 1] == 7 and sets[19, 1] == 18


def test_a_camera_never_pairs_twice_in_one_set():
    sets = pair_by_time([np.array([0, 5 * MS]), np.array([1 * MS])], 10 * MS)
    assert sets.tolist() == [[0, 0], [1, MISSING]]


def test_speed_and_moving_views():
    t = np.arange(5) * 0.1
    corners = np.zeros((5, 4, 2))
    corners[:, :, 0] = (np.arange(5) * 20.0)[:, None]  # 20 px per 0.1 s = 200 px/s
    corners[2] = np.nan  # missed: its neighbours are 0.2 s apart, still within the window
    speed = board_speed_px_s(corners, t)
    assert np.allclose(speed[[0, 1, 3, 4]], 200.0) and np.isnan(speed[2])
    cams = np.stack([corners, corners])
    times = np.stack([t, t + 0.004])  # the second camera 4 ms later: 0.4 px each side of the set's time
    assert not moving_views(cams, times, t + 0.002, max_shift_px=1.0).any()
    times = np.stack([t, t + 0.02])  # 20 ms: 2 px each side
    assert moving_views(cams, times, t + 0.01, max_shift_px=1.0)[:, [0, 1, 3, 4]].all()


def test_readout_marks_smeared_views_of_synchronised_cameras_but_never_most_of_a_camera():
    t = np.arange(7) * 0.1
    corners = np.zeros((7, 4, 2))
    step = np.array([0.0, 1.0, 2.0, 30.0, 60.0, 90.0, 91.0])  # px: a view's speed: to its slower neighbour
    corners[:, :, 0] = step[:, None]
    cams = np.stack([corners, corners])
    times = np.stack([t, t])  # synchronised: no offset at all
    assert not moving_views(cams, times, t, max_shift_px=1.0).any()
    assert not smeared_views(cams, times, 1.0, readout_s=0.0).any()
    # a 20 ms rolling-shutter readout: views faster than 50 px/s (1 px in 20 ms) are smeared
    smeared = smeared_views(cams, times, 1.0, readout_s=0.02, max_fraction=1.0)
    assert smeared[0].tolist() == [False, False, False, True, True, False, False]  # 280 and 300 px/s
    capped = smeared_views(cams, times, 1.0, readout_s=0.02, max_fraction=0.2)
    assert capped.sum(1).tolist() == [1, 1] and capped[0, 4]  # one of 7 views at most: the fastest


def test_pairing_config_names_bad_values():
    import pytest
    from gaitcap.acquisition.boards.pairing import PairingConfig

    with pytest.raises(ValueError, match="readout_ms"):
        PairingConfig(readout_ms=-1)
    with pytest.raises(ValueError, match="max_moving_fraction"):
        PairingConfig(max_moving_fraction=1.5)
