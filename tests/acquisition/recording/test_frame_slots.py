"""Stray frame ids amid real frames, with a camera restart: exactly the strays are left out, every real
frame lands on its true frame set, and the restart is counted once (strays read as no restart)."""

import numpy as np
from gaitcap.acquisition.recording.frame_slots import SLACK_FRAMES, align_frame_slots

PERIOD_NS, T0_NS, FRAMES = 33_333_333, 1_700_000_000_000_000_000, 3000


def test_random_stray_ids_amid_a_restart_are_left_out_and_the_real_frames_placed():
    rng = np.random.default_rng(7)
    series, truth, injected = {}, {}, {}
    for c, cam in enumerate(("cam0", "cam1", "cam2")):
        sets = np.arange(FRAMES)
        ids = np.where(sets >= 1500, sets - 1500, sets) if cam == "cam1" else sets  # cam1 restarts at 1500
        ts = T0_NS + sets * PERIOD_NS + 1000 * c
        n = FRAMES // 20  # 5 % of the messages carry a stray id, at random moments of the trial
        stray = np.where(rng.random(n) < 0.5, 1, -1) * rng.integers(SLACK_FRAMES + 1, 2**52, n)
        series[cam] = (np.concatenate([ids, stray]), np.concatenate([ts, T0_NS + rng.integers(0, FRAMES, n) * PERIOD_NS]))
        truth[cam], injected[cam] = sets, sorted(stray.tolist())
    placed, report = align_frame_slots(series)
    assert report.restarts == {"cam1": 1} and report.dropped == {}
    assert {cam: sorted(ids) for cam, ids in report.strays.items()} == injected
    for cam, (keep, slots) in placed.items():
        assert keep.tolist() == list(range(FRAMES))  # every real frame, none of the strays
        np.testing.assert_array_equal(slots, truth[cam])


def test_a_camera_with_only_stray_ids_gets_no_frames():
    sets = np.arange(100)
    placed, report = align_frame_slots({"cam0": (sets, T0_NS + sets * PERIOD_NS),
                                        "cam1": (np.array([2**40, 2**40 + 1]), T0_NS + np.array([5, 6]) * PERIOD_NS)})
    assert placed["cam1"][0].size == 0 and report.strays == {"cam1": (2**40, 2**40 + 1)}
    np.testing.assert_array_equal(placed["cam0"][1], sets)
