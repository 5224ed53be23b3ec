import numpy as np
import pytest
from gaitcap.acquisition.sync import PassCriteria, camera_fps, check_sync, group_frames

P = 33_333_333


def _stamps(n=90, offsets=(0, 2_000_000, -1_000_000)):
    return {f"c{i}": 10**15 + np.arange(n) * P + o for i, o in enumerate(offsets)}


def test_clean_rig_passes():
    r = check_sync(_stamps(), period_ns=P)
    assert r.passed and r.num_sets == 90
    assert r.spread_ms_max == pytest.approx(3.0) and r.fps["c1"] == pytest.approx(30.0)


def test_drop_is_a_skip_and_set_still_formed():
    ts = _stamps()
    ts["c1"] = np.delete(ts["c1"], [10, 11])
    sets = group_frames(ts, period_ns=P)
    assert not sets.present[10, 1] and sets.present[10, 0]
    assert sets.index[12, 1] == 10  # the frame after the gap lands in its own slot
    r = check_sync(ts, period_ns=P)
    assert r.skips == {"c0": 0, "c1": 2, "c2": 0}
    assert r.problems == ("camera c1: 2 skipped frames",)


def test_duplicates_and_late_start():
    ts = _stamps()
    ts["c0"] = np.insert(ts["c0"], 5, ts["c0"][5] + 1000)
    ts["c2"] = ts["c2"][30:]  # started late: not a skip
    r = check_sync(ts, period_ns=P)
    assert r.duplicates["c0"] == 1 and r.skips["c2"] == 0
    assert any("duplicate" in p for p in r.problems)


def test_spread_and_fps_criteria():
    ts = _stamps(offsets=(0, 15_000_000, -16_000_000))
    r = check_sync(ts, period_ns=P)
    assert r.spread_ms_max == pytest.approx(31.0)
    assert any("spread 31.0 ms > 30.0 ms" in p for p in r.problems)
    # Beyond half a period only frame ids can tell which set a frame belongs to.
    ts = _stamps(offsets=(0, 5_000_000, -25_000_000))
    assert check_sync(ts, period_ns=P).spread_ms_max < 20
    ids = {c: np.arange(90) for c in ts}
    assert check_sync(ts, period_ns=P, frame_ids=ids).spread_ms_max == pytest.approx(30.0)
    slow = {"c0": 10**15 + np.arange(60) * int(1e9 / 27)}
    r = check_sync(slow, period_ns=int(1e9 / 27), criteria=PassCriteria())
    assert "27.00 fps < 28.0" in r.problems[0]
    assert camera_fps(np.array([5])) == 0.0


def test_bad_input():
    with pytest.raises(ValueError, match="period_ns"):
        group_frames({"a": [1]}, period_ns=0)
    with pytest.raises(ValueError, match="no frames"):
        group_frames({"a": []}, period_ns=P)
