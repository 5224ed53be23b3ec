import time

import numpy as np
import pytest
from gaitcap.reconstruction.fits.bspline import (
    FOOT_JOINTS,
    KNEE_JOINTS,
    BSplineBasis,
    banded_least_squares,
    cubic_weights,
)
from gaitcap.reconstruction.fits.implicit import ImplicitFit


def test_cubic_weights_partition_unity_and_are_continuous():
    s = np.linspace(0, 1, 11)
    w = cubic_weights(s)
    assert np.allclose(w.sum(-1), 1.0) and (w >= 0).all()
    # end of one interval == start of the next, shifted by one control point
    assert np.allclose(w[-1, 1:], w[0, :-1]) and w[-1, 0] == pytest.approx(0) and w[0, -1] == pytest.approx(0)


def test_banded_solve_matches_dense_penalised_least_squares():
    basis = BSplineBasis(max_freq_hz=2.0)
    times = np.arange(95) / 30.0
    first, w = basis.locate(times, 0.0, times[-1])
    n_ctrl = basis.intervals(times[-1]) + 3
    rng = np.random.default_rng(0)
    target = rng.normal(size=(len(times), 5))
    dense = np.zeros((len(times), n_ctrl))
    for k in range(4):
        dense[np.arange(len(times)), first + k] += w[:, k]
    gram = dense.T @ dense
    lam = 0.01 * np.mean(np.diag(gram))
    d2 = np.diff(np.eye(n_ctrl), 2, axis=0)
    expected = np.linalg.solve(gram + lam * d2.T @ d2, dense.T @ target)
    got = banded_least_squares(first, w, target, n_ctrl, 0.01)
    assert np.allclose(got, expected, atol=1e-9)


def test_start_follows_band_limited_motion_and_rejects_jitter():
    """The least-squares start reproduces 1.5 Hz motion (gait) and removes 12 Hz jitter."""
    times = 5.0 + np.arange(300) / 30.0  # 10 s, not starting at 0
    slow = 200 * np.sin(2 * np.pi * 1.5 * times) + 30 * times
    jitter = 20 * np.sin(2 * np.pi * 12.0 * times)
    init = np.stack([slow + jitter, 0 * times, 900 + 0 * times], -1)[:, None, :]  # (T, 1, 3) mm
    basis = BSplineBasis()
    weights, feats, span = basis.init(times, init, None)
    assert len(weights) == 1 and weights[0].shape == (basis.intervals(times[-1] - times[0]) + 3, 3)
    fitted = np.asarray(basis.points(weights, feats))[0, :, 0]  # x (T,)
    assert np.abs(fitted - slow)[15:-15].max() < 0.1 * 20  # jitter cut to under a tenth
    traj = basis.trajectory(weights, span, 1)
    between = traj(times[100:102].mean()[None])[0, 0, 0]
    assert between == pytest.approx(0.5 * (fitted[100] + fitted[101]), abs=2.0)
    assert np.allclose(traj(times)[:, 0, 0], fitted, atol=0.05)
    with pytest.raises(ValueError, match="outside the fitted span"):
        traj(np.array([times[0] - 0.5]))


def test_size_and_start_time_grow_linearly_with_the_trial():
    """A 10-minute trial at 30 fps: 16 control points per second and a start in well under a second."""
    basis = BSplineBasis()
    assert basis.intervals(600.0) == 9600 and basis.intervals(30.0) == 480
    times = np.arange(18_000) / 30.0
    init = np.random.default_rng(1).normal(0, 300, (18_000, 26, 3))
    t0 = time.perf_counter()
    (weights,), (((index, w),), order), _ = basis.init(times, init, None)
    assert time.perf_counter() - t0 < 5.0
    assert weights.shape == (9603, 78) and index.shape == (18_000, 4) and w.shape == (18_000, 4)
    assert np.array_equal(order, np.arange(26))


def test_bad_band_limit_is_refused():
    with pytest.raises(ValueError, match="max_freq_hz"):
        BSplineBasis(max_freq_hz=0.0)
    with pytest.raises(ValueError, match="knots_per_cycle"):
        BSplineBasis(knots_per_cycle=-1.0)


def test_default_implicit_fit_is_the_spline():
    assert ImplicitFit().model == BSplineBasis(max_freq_hz=8.0, knots_per_cycle=2.0, fast_max_freq_hz=12.0,
                                               fast_joints=KNEE_JOINTS)


def _landing_walk(times_s: np.ndarray, names: tuple[str, ...], land_s: float) -> np.ndarray:
    """(T, J, 3) mm: a body moving smoothly (0.8 m/s forward, 1 Hz bob) whose left foot comes down at
    400 mm/s and lands at ``land_s``; its heel dips 10 mm below its stance height at the landing and comes
    back up within ~50 ms (the heel rocker), as real heels do (docs/gait.md)."""
    t = np.asarray(times_s, dtype=np.float64)
    base = np.random.default_rng(0).normal(0, 250, (len(names), 3))
    pts = base[None] + np.stack([800 * t, 0 * t, 30 * np.sin(2 * np.pi * t)], -1)[:, None]
    descent = np.minimum(400.0 * np.clip(land_s - t, 0, None), 150.0)
    for name in ("left_ankle", "left_big_toe", "left_small_toe"):
        pts[:, names.index(name), 2] += descent
    dip = np.where(t < land_s, -10.0, -10.0 * np.exp(-(t - land_s) / 0.02))
    pts[:, names.index("left_heel"), 2] += descent + dip
    return pts


def test_feet_on_their_own_grid_keep_the_landing_the_body_grid_rounds():
    """fast_max_freq_hz: the feet's 15 Hz grid places the heel's lowest point (where a heel-first landing's
    strike is found) nearer the truth than the body's 8 Hz grid, and the rest of the body is fitted exactly as
    without it."""
    from gaitcap.reconstruction.skeletons import get_skeleton

    names = tuple(get_skeleton("halpe26").joint_names)
    land_s = 1.01  # between two frames
    times = np.arange(60) / 30.0
    truth = _landing_walk(times, names, land_s)
    fine = np.arange(0.85, 1.2, 0.001)
    heel = names.index("left_heel")
    fitted, lowest = {}, {}
    for hz in (None, 15.0):
        basis = BSplineBasis(fast_max_freq_hz=hz, fast_joints=FOOT_JOINTS)
        weights, _, span = basis.init(times, truth, None, joint_names=names)
        fitted[hz] = basis.trajectory(weights, span, len(names))(fine)
        lowest[hz] = fine[np.argmin(fitted[hz][:, heel, 2])] - land_s
    assert abs(lowest[15.0]) < 0.015 and abs(lowest[15.0]) < 0.7 * abs(lowest[None])
    feet = [names.index(n) for n in FOOT_JOINTS if n in names]
    assert {g.max_freq_hz: g.joints for g in span.grids} == {8.0: tuple(sorted(set(range(len(names))) - set(feet))),
                                                            15.0: tuple(sorted(feet))}
    body = [j for j in range(len(names)) if j not in feet]
    assert np.allclose(fitted[15.0][:, body], fitted[None][:, body], atol=1e-6)
    assert not np.allclose(fitted[15.0][:, feet], fitted[None][:, feet], atol=0.5)
    # without joint names (or without the option) one grid carries every joint
    assert [g.joints for g in BSplineBasis(fast_max_freq_hz=15.0).grids(len(names))] == [tuple(range(len(names)))]
    with pytest.raises(ValueError, match="fast_max_freq_hz"):
        BSplineBasis(fast_max_freq_hz=0.0)


def test_the_knees_own_grid_follows_a_quick_extension_the_body_grid_lags():
    """The default: the knees on a 12 Hz grid of their own follow a knee that swings 60 mm forward within
    about 100 ms (the quick extension before heel strike) closer than the body's 8 Hz grid, and every other
    joint is fitted exactly as on the body's grid."""
    from gaitcap.reconstruction.skeletons import get_skeleton

    names = tuple(get_skeleton("halpe26").joint_names)
    times = np.arange(60) / 30.0
    t = times[:, None]
    truth = np.random.default_rng(1).normal(0, 250, (len(names), 3))[None] + np.stack(
        [800 * t, 0 * t, 30 * np.sin(2 * np.pi * t)], -1)
    knee = names.index("left_knee")
    truth[:, knee, 0] += 60.0 / (1.0 + np.exp(-(times - 1.0) / 0.02))  # 60 mm, 10-90 % within 90 ms
    err, fitted = {}, {}
    for label, basis in (("body", BSplineBasis(fast_max_freq_hz=None)), ("knees", BSplineBasis())):
        weights, _, span = basis.init(times, truth, None, joint_names=names)
        fitted[label] = basis.trajectory(weights, span, len(names))(times)
        err[label] = float(np.sqrt(np.mean((fitted[label][:, knee] - truth[:, knee]) ** 2)))
    assert err["knees"] < 0.7 * err["body"], err
    others = [j for j in range(len(names)) if names[j] not in KNEE_JOINTS]
    assert np.allclose(fitted["knees"][:, others], fitted["body"][:, others], atol=1e-6)
    assert {g.max_freq_hz for g in span.grids} == {8.0, 12.0}
