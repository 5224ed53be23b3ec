"""The validation's figures (PNG bytes): Bland-Altman plots of the step parameters, angle overlays."""

from __future__ import annotations

import io

import numpy as np
from gaitcap.reconstruction.validation.steps import PARAMETERS

SIDE_COLOURS = {"left": "#1f77b4", "right": "#d62728"}


def _png(fig) -> bytes:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()


def bland_altman_png(result: dict) -> bytes:
    """One panel per step parameter: difference (trial - reference) against the mean of the two, per side,
    with the bias and the 95 % limits of agreement."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 4, figsize=(13, 6))
    for ax, name in zip(axes.ravel(), PARAMETERS, strict=True):
        for side, colour in SIDE_COLOURS.items():
            v = np.array([[np.nan if x is None else x for x in p["values"][name]] for p in result["step_pairs"]
                          if p["foot"] == side], float).reshape(-1, 2)
            v = v[np.isfinite(v).all(axis=1)]
            ax.scatter(v.mean(axis=1), v[:, 0] - v[:, 1], s=18, color=colour, label=side)
        stats = result["parameters"].get(name, {}).get("all", {})
        for key, style in (("bias", "-"), ("loa_low", "--"), ("loa_high", "--")):
            if stats.get(key) is not None and np.isfinite(stats[key]):
                ax.axhline(stats[key], color="k", ls=style, lw=0.8)
        ax.set_title(f"{name} (n={stats.get('n', 0)})", fontsize=9)
        ax.set_xlabel("mean of trial and reference", fontsize=8)
        ax.set_ylabel("trial - reference", fontsize=8)
        ax.tick_params(labelsize=7)
    axes.ravel()[0].legend(fontsize=7)
    fig.suptitle("Bland-Altman: bias (solid) and 95 % limits of agreement (dashed)", fontsize=10)
    fig.tight_layout()
    return _png(fig)


def angles_png(result: dict, curves: dict) -> bytes:
    """Trial and reference curves per variable and side over the trial's clock (``curves``: (variable,
    side) -> (times s, trial deg, reference deg))."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    variables = sorted({v for v, _ in curves})
    fig, axes = plt.subplots(len(variables) or 1, 2, figsize=(11, 2.2 * max(len(variables), 1)), squeeze=False)
    for i, var in enumerate(variables):
        for j, side in enumerate(("left", "right")):
            ax = axes[i, j]
            if (var, side) in curves:
                t, a, b = curves[(var, side)]
                ax.plot(t, a, color=SIDE_COLOURS[side], lw=1.2, label="gaitcap")
                ax.plot(t, b, color="k", lw=1.0, ls="--", label="reference")
            ax.set_title(f"{side} {var} (deg)", fontsize=9)
            ax.tick_params(labelsize=7)
    axes[0, 0].legend(fontsize=7)
    axes[-1, 0].set_xlabel("trial time (s)", fontsize=8)
    fig.tight_layout()
    return _png(fig)
