"""Event matching: errors trial - reference, missed and extra events, edges of the clip not judged."""

import numpy as np
from gaitcap.reconstruction.validation.events import compare_events, event_summary


def test_events_are_matched_per_side_with_missed_and_extra():
    ref = {"heel_strike": {"left": np.array([1.5, 2.6, 3.7]), "right": np.array([2.05, 3.15])},
           "toe_off": {"left": np.array([2.2]), "right": np.array([1.55])}}
    lag = 0.5  # reference time = trial time + 0.5
    trial = {"heel_strike": {"left": np.array([0.95, 2.0]), "right": np.array([1.58, 2.62, 2.9])},
             "toe_off": {"left": np.array([1.7]), "right": np.array([1.05])}}
    out = {(m.side, m.kind): m for m in compare_events(trial, ref, lag_s=lag, span_s=(0.0, 4.0))}
    left = out[("left", "heel_strike")]
    assert np.allclose(left.errors_s, [-0.05, -0.1]) and left.missed_s == (3.2,) and left.extra_s == ()
    right = out[("right", "heel_strike")]
    assert np.allclose(right.errors_s, [0.03, -0.03]) and right.extra_s == (2.9,)
    s = event_summary(left, 30.0)
    assert s["n"] == 2 and s["missed"] == 1 and np.isclose(s["signed_median_frames"], -0.075 * 30)
    assert np.isclose(s["abs_median_ms"], 75.0)
    # events within edge_s of the common span's ends are not judged
    near_end = compare_events({"heel_strike": {"left": [2.95]}}, {"heel_strike": {"left": [3.45]}}, lag_s=lag,
                              span_s=(0.0, 3.0))
    assert near_end[0].missed_s == () and near_end[0].extra_s == ()
