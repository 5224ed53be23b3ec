"""Angle agreement: the offset, the RMSE with and without it, r and the cycles."""

import numpy as np
from gaitcap.reconstruction.validation.angles import compare_angle


def test_offset_rmse_and_cycles():
    ref_t = np.arange(0, 4.0, 0.01)
    ref = 30 * np.sin(2 * np.pi * ref_t / 1.1)
    trial_t = np.arange(0, 3.0, 1 / 30)
    trial = 30 * np.sin(2 * np.pi * (trial_t + 0.4) / 1.1) + 5.0 + 1.0 * np.sin(2 * np.pi * 3.0 * trial_t)
    a = compare_angle("knee_flexion", "left", trial_t, trial, ref_t, ref, lag_s=0.4,
                      heel_strikes_s=np.array([0.1, 1.2, 2.3]))
    assert abs(a.offset_deg - 5.0) < 0.1
    assert abs(a.rmse_after_offset_deg - np.sqrt(0.5)) < 0.05
    assert abs(a.rmse_deg - np.sqrt(25 + 0.5)) < 0.1 and a.r > 0.99
    assert len(a.cycles) == 2 and all(c[1] < 1.0 for c in a.cycles)
    assert abs(a.reference_min_deg + 30) < 0.1 and a.n == len(trial_t)
    assert compare_angle("knee_flexion", "left", trial_t, trial, ref_t, ref, lag_s=10.0) is None
