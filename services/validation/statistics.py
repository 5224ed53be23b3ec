"""Agreement statistics of paired measurements (trial, reference) of one parameter.

bias = mean(trial - reference); 95 % limits of agreement (Bland & Altman 1986) = bias +- 1.96 SD of the
differences (SD with n - 1): the same lines pingouin's ``plot_blandaltman`` draws for the same pairs,
which tests/services/validation/test_statistics.py checks; MAE = mean |difference|;
ICC(A,1) (McGraw & Wong 1996: two-way random effects, absolute agreement, single measurement; Shrout &
Fleiss ICC(2,1)) from ``pingouin.intraclass_corr`` with its 95 % confidence interval. Pairs with a missing
value are left out; n counts the rest. ICC needs at least 3 pairs and some spread between them (else NaN).
"""

from __future__ import annotations

import math
import warnings

import numpy as np

LOA_Z = 1.96


def _icc(x: np.ndarray) -> tuple[float, list[float]]:
    nan = float("nan")
    if len(x) < 3 or np.ptp(x) == 0:
        return nan, [nan, nan]
    import pandas as pd
    import pingouin

    df = pd.DataFrame({"target": np.r_[np.arange(len(x)), np.arange(len(x))],
                       "rater": ["trial"] * len(x) + ["reference"] * len(x), "value": np.r_[x[:, 0], x[:, 1]]})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        table = pingouin.intraclass_corr(df, targets="target", raters="rater", ratings="value")
    row = table[table["Type"].isin(["ICC2", "ICC(A,1)"])].iloc[0]
    ci = [float(v) for v in row["CI95"]] if "CI95" in row else [float(v) for v in row["CI95%"]]
    return float(row["ICC"]), ci


def agreement(pairs) -> dict:
    """``pairs``: (trial, reference) values -> {n, bias, sd, loa_low, loa_high, mae, icc, icc_ci95,
    trial_mean, reference_mean} (NaN where n is too small)."""
    x = np.array([p for p in pairs if all(v is not None and math.isfinite(v) for v in p)], float).reshape(-1, 2)
    nan = float("nan")
    d = x[:, 0] - x[:, 1]
    sd = float(d.std(ddof=1)) if len(d) > 1 else nan
    bias = float(d.mean()) if len(d) else nan
    icc, ci = _icc(x)
    return {"n": len(d), "bias": bias, "sd": sd, "loa_low": bias - LOA_Z * sd, "loa_high": bias + LOA_Z * sd,
            "mae": float(np.abs(d).mean()) if len(d) else nan, "icc": icc, "icc_ci95": ci,
            "trial_mean": float(x[:, 0].mean()) if len(d) else nan,
            "reference_mean": float(x[:, 1].mean()) if len(d) else nan}
