import time

import numpy as np
import pytest
from gaitcap.reconstruction.fits.bspline import BSplineBasis, banded_least_squares, cubic_weights
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
    assert weights.shape == (basis.intervals(times[-1] - times[0]) + 3, 3)
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
    weights, (index, w), _ = basis.init(times, init, None)
    assert time.perf_counter() - t0 < 5.0
    assert weights.shape == (9603, 78) and index.shape == (18_000, 4) and w.shape == (18_000, 4)


def test_bad_band_limit_is_refused():
    with pytest.raises(ValueError, match="max_freq_hz"):
        BSplineBasis(max_freq_hz=0.0)
    with pytest.raises(ValueError, match="knots_per_cycle"):
        BSplineBasis(knots_per_cycle=-1.0)


def test_default_implicit_fit_is_the_spline():
    assert ImplicitFit().model == BSplineBasis(max_freq_hz=8.0, knots_per_cycle=2.0)
