"""Stray frame ids amid real frames, with a camera restart: exactly the strays are left out, every real
frame lands on its true frame set, and the restart is counted once (strays read as no restart)."""

import numpy as np
from gaitcap.acquisition.recording.frame_slots import SLACK_FRAMES, SlotReport, align_frame_slots

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


def test_a_frame_with_a_good_id_and_a_timestamp_far_off_is_left_out_for_its_timestamp(caplog):
    """Frame 50 of cam0 stamped an hour late, an hour early or 10 min late: it alone is left out (never
    taken for a counter restart, which would keep it with its wrong time), and said to be for its
    timestamp, not its id."""
    sets = np.arange(300)
    for off_s in (3600, -3600, 600):
        ts = T0_NS + sets * PERIOD_NS
        bad = ts.copy()
        bad[50] += off_s * 10**9
        caplog.clear()
        placed, report = align_frame_slots({"cam0": (sets, bad), "cam1": (sets, ts + 1000), "cam2": (sets, ts + 2000)})
        assert report.strays == {"cam0": (50,)} and report.restarts == {} and report.dropped == {}, off_s
        assert report.in_span((50, 2**40)) == (50,)
        np.testing.assert_array_equal(placed["cam0"][1], np.delete(sets, 50))
        assert "camera cam0: 1 frame with a timestamp far from that of its frame id (from frame 50) was left out" \
            in caplog.text
        assert "frame ids far outside" not in caplog.text


def test_the_report_says_one_frame_and_one_time_in_the_singular():
    one = SlotReport(restarts={"cam0": 1}, moved={"cam0": 1}, dropped={"cam1": 1}, strays={"cam2": (5, 2**40)},
                     span=(0, 10))
    assert one.messages() == [
        "camera cam2: 1 frame with a frame id far outside the recording (from 1099511627776) was left out",
        "camera cam2: 1 frame with a timestamp far from that of its frame id (from frame 5) was left out",
        "camera cam0: frame counter restarted 1 time within the recording (camera restart); 1 frame placed by "
        "timestamp",
        "camera cam1: 1 frame repeats a frame already recorded and was left out"]
    two = SlotReport(restarts={"cam0": 2}, moved={"cam0": 3}, dropped={"cam1": 2}, strays={"cam2": (2**40, -(2**40))})
    assert two.messages() == [
        "camera cam2: 2 frames with frame ids far outside the recording (from 1099511627776) were left out",
        "camera cam0: frame counter restarted 2 times within the recording (camera restart); 3 frames placed by "
        "timestamp",
        "camera cam1: 2 frames repeat a frame already recorded and were left out"]
