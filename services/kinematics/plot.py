"""The kinematics figure (the report's page, ``kinematics.png``): gait-cycle curves per side (mean +- SD) over
the normal-gait band."""

from __future__ import annotations

import io

import numpy as np
from gaitcap.reconstruction.kinematics.angles import VARIABLES

COLORS = {"left": "#1f77b4", "right": "#d62728"}


def side_curves_png(k: dict, *, width_in: float = 10.0, title: str = "") -> bytes:
    """The report's figure from a ``kinematics.json`` dict (norms chosen for the patient): one panel per
    variable and side, two variables to a row (left, right, left, right), each with the side's mean +- SD
    (degrees) over the normal band (grey, mean +- 1 SD) where there is one that the table compares with
    (:func:`gaitcap.reconstruction.kinematics.key_norms.drawn_bands`); ``title`` above them."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    names = [n for n in VARIABLES if n in k.get("curves", {})]
    rows = max(1, (len(names) + 1) // 2)
    fig = Figure(figsize=(width_in, 1.75 * rows + 0.4), dpi=110)
    axes = fig.subplots(rows, 4, squeeze=False).ravel()
    from gaitcap.reconstruction.kinematics.key_norms import drawn_bands

    pct, bands = np.arange(101), drawn_bands(k)
    for i, (name, side) in enumerate((n, s) for n in names for s in COLORS):
        ax, c = axes[i], k["curves"][name][side]
        band = bands.get(name)
        if band is not None:
            m, sd = np.asarray(band["mean_deg"], float), np.asarray(band["sd_deg"], float)
            ax.fill_between(pct, m - sd, m + sd, color="0.85", lw=0)
        mean = np.asarray([np.nan if v is None else v for v in c["mean_deg"]], float)
        sd = np.asarray([np.nan if v is None else v for v in c["sd_deg"]], float)
        if c.get("n_cycles"):
            ax.plot(pct, mean, color=COLORS[side], lw=1.3)
            ax.fill_between(pct, mean - sd, mean + sd, color=COLORS[side], alpha=0.18, lw=0)
        ax.set_title(f"{VARIABLES[name].label}, {side} (n={c.get('n_cycles', 0)})", fontsize=6.5)
        ax.set_xlim(0, 100)
        ax.tick_params(labelsize=5.5)
        ax.grid(alpha=0.3)
    for ax in axes[2 * len(names):]:
        ax.set_axis_off()
    fig.supxlabel("% of the gait cycle; degrees", fontsize=7)
    if title:
        fig.suptitle(title, fontsize=8)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()


def figure_title(k: dict) -> str:
    """Whose band the figure shows and what is not drawn, for the standalone PNG."""
    norms = k.get("norms") or {}
    band = (f"grey: normal mean +- 1 SD, {norms['population']}" if norms.get("bands")
            else norms.get("no_reference") or "no normal band")
    held = "; not measured: " + ", ".join(n.replace("_", " ") for n in k.get("not_measured") or {}) \
        if k.get("not_measured") else ""
    return f"Joint kinematics ({band}{held})"
