"""Time and space alignment on synthetic walks: the lag and the rigid transform given are found; a pair
that does not match is refused, naming what did not match."""

import numpy as np
import pytest
from gaitcap.reconstruction.validation.align import (
    AlignmentError,
    align_space,
    find_lag,
    fit_rigid,
    swap_sides,
)


def _heel(t, phase):
    """A heel height (mm): 1.1 s strides, lifts of ~120 mm, flat on the floor in stance."""
    x = np.sin(2 * np.pi * (t / 1.1 + phase))
    return 20 + 120 * np.clip(x, 0, None) ** 2 + 3 * np.sin(7.3 * t)


def _rotation(deg, axis):
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    i, j = [k for k in range(3) if k != axis]
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


def test_lag_is_found_over_a_longer_reference_at_its_own_rate():
    ref_t = np.arange(0, 6.0, 0.01)  # 100 Hz, 6 s
    trial_t = np.arange(0, 3.0, 1 / 30)  # 30 fps, 3 s, starting 1.737 s into the reference
    lag = 1.737
    ref = {"left": _heel(ref_t, 0.0), "right": _heel(ref_t, 0.5)}
    rng = np.random.default_rng(0)
    trial = {s: _heel(trial_t + lag, p) + 300 + rng.normal(0, 2, len(trial_t)) for s, p in (("left", 0.0), ("right", 0.5))}
    candidates = find_lag(trial_t, trial, ref_t, ref)
    found = candidates[0]
    assert abs(found.lag_s - lag) < 0.003
    # a stride (1.1 s) away correlates too: a candidate for the space fit to rule out
    assert any(abs(abs(c.lag_s - lag) - 1.1) < 0.02 for c in candidates[1:])
    assert found.correlation > 0.99 and found.crossed_correlation < found.correlation
    assert 2.9 < found.overlap_s < 3.01


def test_another_walk_is_refused():
    ref_t = np.arange(0, 6.0, 0.01)
    trial_t = np.arange(0, 3.0, 1 / 30)
    ref = {"left": _heel(ref_t, 0.0), "right": _heel(ref_t, 0.3)}
    rng = np.random.default_rng(1)
    other = {s: rng.normal(0, 50, len(trial_t)) for s in ("left", "right")}
    with pytest.raises(AlignmentError, match="not this walk"):
        find_lag(trial_t, other, ref_t, ref)


def test_rigid_fit_finds_the_transform_and_names_a_bad_fit():
    rng = np.random.default_rng(2)
    t = np.arange(0, 2.0, 0.01)
    ref = {n: rng.normal(0, 400, (len(t), 3)) for n in ("left_heel", "right_heel", "left_hip")}
    rot = _rotation(33.0, 2) @ _rotation(4.0, 0)
    shift = np.array([1200.0, -300.0, 45.0])
    trial_t = t[50:150:3] - t[50]
    trial = {n: p[50:150:3] @ rot.T + shift + rng.normal(0, 1.0, (len(trial_t), 3)) for n, p in ref.items()}
    fit = align_space(trial_t, trial, t, ref, t[50], joints=("left_heel", "right_heel", "left_hip"))
    assert np.allclose(fit.rotation, rot, atol=1e-3) and np.allclose(fit.translation_mm, shift, atol=2.0)
    assert fit.residual_mm < 3.0
    r, s = fit_rigid(ref["left_heel"], ref["left_heel"] @ rot.T + shift)
    assert np.allclose(r, rot) and np.linalg.det(r) > 0
    trial["left_hip"] = trial["left_hip"] + 500.0
    with pytest.raises(AlignmentError, match="left_hip"):
        align_space(trial_t, trial, t, ref, t[50], joints=("left_heel", "right_heel", "left_hip"))


def test_swapped_sides_fit_only_once_exchanged():
    """A mirrored walk (left and right labels exchanged) fits no proper rotation; exchanged back, it fits."""
    rng = np.random.default_rng(3)
    t = np.arange(0, 2.0, 0.01)
    base = rng.normal(0, 300, (len(t), 3))
    ref = {f"{s}_{j}": base + np.array([0.0, sign * 100.0, z]) + rng.normal(0, 40, (len(t), 3))
           for s, sign in (("left", 1), ("right", -1)) for j, z in (("heel", 0.0), ("ankle", 60.0), ("hip", 900.0))}
    trial = {n: p @ _rotation(20.0, 2).T for n, p in swap_sides(ref).items()}
    joints = tuple(ref)
    with pytest.raises(AlignmentError, match="do not fit"):
        align_space(t, trial, t, ref, 0.0, joints=joints)
    assert align_space(t, trial, t, swap_sides(ref), 0.0, joints=joints).residual_mm < 1e-6
