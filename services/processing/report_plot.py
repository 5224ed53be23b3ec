"""PNG of the heel forward and lateral traces with the detected contacts (like the paper's Figure 2): plotting
is I/O, so it lives with the trial outputs, not in the pure gait analysis."""

from __future__ import annotations

import io
from collections.abc import Sequence

import numpy as np
from gaitcap.reconstruction.gait.config import GaitConfig
from gaitcap.reconstruction.gait.plausibility import implausible_heel_frames
from gaitcap.reconstruction.gait.report import GaitReport
from gaitcap.reconstruction.gait.tracks import HEEL, SIDES, FootTracks

COLOURS = {"left": "tab:blue", "right": "tab:red"}


def _axes(report: GaitReport) -> tuple[np.ndarray, np.ndarray]:
    """Forward and lateral unit vectors: the first pass's direction of progression and its left normal."""
    d = np.asarray(report.passes[0].direction if report.passes else (1.0, 0.0), dtype=np.float64)
    return d, np.array([-d[1], d[0]])


def heel_traces_png(report: GaitReport, points_mm: np.ndarray, times_s: np.ndarray,
                    joint_names: Sequence[str], *, config: GaitConfig = GaitConfig(),
                    width_in: float = 10.0) -> bytes:
    """PNG bytes: heel forward (top) and lateral (bottom) position (mm) over time (s) for both feet of the
    (T, J, 3) trajectory, the report's contacts as dots at their heel strike, passes shaded. Axes follow
    the first pass's direction of progression. Frames whose heel height no walking heel has are not drawn."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    tracks = FootTracks.from_points(points_mm, times_s, joint_names, config=config)
    fwd, lat = _axes(report)
    fig = Figure(figsize=(width_in, 6.0), dpi=100)
    ax_f, ax_l = fig.subplots(2, 1, sharex=True)
    origin = tracks.frames_mm[0, HEEL["left"], :2]
    for side in SIDES:
        xy = tracks.frames_mm[:, HEEL[side], :2] - origin
        shown = tracks.valid[:, HEEL[side]] & ~implausible_heel_frames(tracks.frames_mm[:, HEEL[side], 2])
        xy = np.where(shown[:, None], xy, np.nan)  # a heel below the floor or flying is an error, not drawn
        ax_f.plot(tracks.times_s, xy @ fwd, color=COLOURS[side], lw=1.0, label=f"{side} heel")
        ax_l.plot(tracks.times_s, xy @ lat, color=COLOURS[side], lw=1.0)
        contacts = [c for c in report.contacts if c.foot == side and c.valid]
        if contacts:
            t = np.array([c.heel_strike_s for c in contacts])
            p = np.array([c.heel_mm[:2] for c in contacts]) - origin
            ax_f.plot(t, p @ fwd, "o", color=COLOURS[side], ms=4)
            ax_l.plot(t, p @ lat, "o", color=COLOURS[side], ms=4)
    if report.walkway is not None:  # the walkway's footfalls, brought into the kinematic frame and clock
        for side in SIDES:
            rows = [r for r in report.walkway.contacts if r.foot == side]
            if rows:
                t = np.array([r.kinematic_time_s for r in rows])
                p = np.array([r.walkway_heel_in_kinematic_mm for r in rows]) - origin
                ax_f.plot(t, p @ fwd, "x", color=COLOURS[side], ms=7, label=f"walkway {side}")
                ax_l.plot(t, p @ lat, "x", color=COLOURS[side], ms=7)
    for p in report.passes:
        for ax in (ax_f, ax_l):
            ax.axvspan(p.start_s, p.end_s, color="0.9", zorder=0)
    ax_f.set_ylabel("heel forward (mm)")
    ax_l.set_ylabel("heel lateral (mm)")
    ax_l.set_xlabel("time (s)")
    ax_f.legend(loc="upper right", fontsize=8)
    steps, passes = report.summary.num_steps, report.summary.num_passes
    ax_f.set_title(f"{steps} step{'s' * (steps != 1)}, {passes} pass{'es' * (passes != 1)}; dots: heel strikes")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()
