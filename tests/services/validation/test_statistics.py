"""The agreement statistics against the maintained libraries that define them: the bias and 95 % limits
of agreement are the lines pingouin's Bland-Altman plot draws for the same pairs, and the ICC is pingouin's
ICC2 (McGraw & Wong's ICC(A,1))."""

import numpy as np
import pytest
from gaitcap.services.validation.statistics import agreement


def _pingouin_lines(x: np.ndarray, y: np.ndarray) -> list[float]:
    """The y values of the horizontal lines pingouin.plot_blandaltman draws (bias and the two limits; its
    line at zero difference left out)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pingouin

    ax = pingouin.plot_blandaltman(x, y, agreement=1.96, annotate=False)
    ys = sorted({round(float(line.get_ydata()[0]), 9) for line in ax.lines
                 if len(set(np.ravel(line.get_ydata()))) == 1 and float(line.get_ydata()[0]) != 0.0})
    plt.close(ax.figure)
    return ys


@pytest.mark.parametrize("seed", [0, 1])
def test_bias_and_limits_are_the_lines_pingouin_draws(seed):
    rng = np.random.default_rng(seed)
    ref = rng.normal(600.0, 40.0, 25)
    trial = ref + rng.normal(5.0, 12.0, 25)
    got = agreement(list(zip(trial, ref, strict=True)))
    assert got["n"] == 25
    assert [got["loa_low"], got["bias"], got["loa_high"]] == pytest.approx(_pingouin_lines(trial, ref), abs=1e-6)


def test_pairs_with_a_missing_value_are_left_out_and_too_few_give_nan():
    got = agreement([(1.0, 1.5), (2.0, None), (float("nan"), 3.0), (4.0, 3.0)])
    assert got["n"] == 2 and got["bias"] == pytest.approx(0.25) and np.isnan(got["icc"])
    assert np.isnan(agreement([])["bias"])
