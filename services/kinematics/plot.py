"""The kinematics page of a report: gait-cycle curves per side (mean +- SD) over the normal-gait band."""

from __future__ import annotations

import io

import numpy as np
from gaitcap.reconstruction.kinematics.angles import VARIABLES
from gaitcap.reconstruction.kinematics.report import KinematicsReport

COLORS = {"left": "#1f77b4", "right": "#d62728"}


def curves_png(report: KinematicsReport, *, title: str = "Joint kinematics") -> bytes:
    """A 3 x 3 grid, one panel per variable: each side's mean +- SD (n cycles in the legend) and the norm
    band (mean +- SD, grey) where there is one; degrees over % of the gait cycle."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 9), dpi=90)
    axes = fig.subplots(3, 3).ravel()
    pct = np.arange(101)
    for ax, (name, var) in zip(axes, VARIABLES.items(), strict=True):
        if name in report.not_measured:  # held by the fit: say so instead of drawing its prior
            ax.set_title(var.label, fontsize=9)
            ax.text(0.5, 0.5, "not measured:\n" + report.not_measured[name].replace(": ", ":\n"),
                    ha="center", va="center", fontsize=7, transform=ax.transAxes, wrap=True)
            ax.set_xticks([])
            ax.set_yticks([])
            continue
        band = report.norms.get(name)
        if band is not None:
            ax.fill_between(pct, band.mean - band.sd, band.mean + band.sd, color="0.85", label="norm")
        for side, color in COLORS.items():
            cc = report.curves[name][side]
            if cc.n:
                ax.plot(pct, cc.mean, color=color, lw=1.4, label=f"{side} (n={cc.n})")
                if cc.n > 1:
                    ax.fill_between(pct, cc.mean - cc.sd, cc.mean + cc.sd, color=color, alpha=0.15)
        ax.set_title(var.label, fontsize=9)
        ax.set_xlim(0, 100)
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=7)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=6, loc="best")
    for ax in axes[6:]:
        ax.set_xlabel("% gait cycle", fontsize=8)
    for ax in axes[::3]:
        ax.set_ylabel("deg", fontsize=8)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()


def side_curves_png(k: dict, *, width_in: float = 10.0) -> bytes:
    """The report's figure from a ``kinematics.json`` dict (norms chosen for the patient): one panel per
    variable and side, two variables to a row (left, right, left, right), each with the side's mean +- SD
    (degrees) over the normal band (grey, mean +- 1 SD) where there is one."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    names = [n for n in VARIABLES if n in k.get("curves", {})]
    rows = max(1, (len(names) + 1) // 2)
    fig = Figure(figsize=(width_in, 1.75 * rows + 0.4), dpi=110)
    axes = fig.subplots(rows, 4, squeeze=False).ravel()
    pct, bands = np.arange(101), (k.get("norms") or {}).get("bands") or {}
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
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()
