"""Writing one processing stage's files (npz, TRC, gait JSON/CSV, report PNG; the viewer files are
:mod:`gaitcap.services.processing.viewers`) and turning a
GaitReport into the catalog's step rows and summary. Every file is written to a temporary name and
renamed, so a reader never sees half a file."""

from __future__ import annotations

import io
import json
import logging
from pathlib import Path

import numpy as np
from gaitcap.acquisition.fileio import atomic_savez, atomic_write_bytes, atomic_write_text
from gaitcap.reconstruction.jsonable import finite_or_none, json_ready
from gaitcap.reconstruction.result import Reconstruction
from gaitcap.services.processing.artifacts import TrialFiles
from gaitcap.services.processing.pipeline import dense_grid, spline_sampler

log = logging.getLogger(__name__)

STEP_COLUMNS = ("step_length_mm", "stride_length_mm", "step_width_mm", "step_time_s", "stride_time_s",
                "stance_pct", "swing_pct", "double_support_pct", "confidence")
SUMMARY_PARAMS = (("step_length_mm", "mm"), ("stride_length_mm", "mm"), ("step_width_mm", "mm"),
                  ("step_time_s", "s"), ("stance_pct", "%"), ("double_support_pct", "%"))


def steps_of(report) -> list[dict]:
    """Catalog step rows: side, time_s, then the main parameters (units in the names), and ``excluded``:
    why the step is not counted in the summary ("" when it is)."""
    return [{"side": s.foot, "time_s": round(float(s.heel_strike_s), 3), "pass_no": s.pass_index + 1,
             **{k: finite_or_none(getattr(s, k)) for k in STEP_COLUMNS}, "excluded": s.excluded} for s in report.steps]


def summary_of(report) -> dict[str, dict]:
    """Catalog summary: cadence, speed, step count and mean +- SD of the main parameters."""
    s = report.summary
    out = {"gait_speed_m_per_s": {"mean": finite_or_none(s.gait_speed_m_s), "unit": "m/s"},
           "cadence_steps_per_min": {"mean": finite_or_none(s.cadence_steps_min), "unit": "steps/min"}}
    for name, unit in SUMMARY_PARAMS:
        stats = s.parameters.get(name, {}).get("all")
        if stats is not None:
            out[name] = {"mean": finite_or_none(stats.mean), "sd": finite_or_none(stats.sd), "unit": unit}
    sym = s.asymmetry_pct.get("step_length_mm")
    if sym is not None:
        out["step_length_asymmetry_pct"] = {"mean": finite_or_none(sym), "unit": "%"}
    out["steps_count"] = {"mean": float(s.num_steps), "unit": ""}
    return out


def write_npz(path, traj: Reconstruction) -> None:
    """The one result file of the worker, ``gaitcap process`` and ``gaitcap reconstruct``: ``points_mm``
    (T, J, 3), ``times_s`` (T,), ``joint_names``, ``num_views`` (T, J; empty for a continuous fit),
    ``method``, ``camera_names`` and, for a continuous fit, its dense samples ``dense_times_s`` (G,) and
    ``dense_points_mm`` (G, J, 3) on which the gait events are found (read back by :func:`read_npz`)."""
    dense = {}
    if traj.trajectory is not None:
        grid = dense_grid(traj.times_s)
        dense = {"dense_times_s": grid, "dense_points_mm": np.asarray(traj.sample(grid))}
    atomic_savez(path, points_mm=traj.points_mm, times_s=traj.times_s, joint_names=np.array(traj.joint_names),
                 num_views=traj.quality if traj.quality is not None else np.zeros(0),
                 method=np.array(traj.method), camera_names=np.array(traj.camera_names, dtype=str), **dense)


def read_npz(path: Path) -> tuple[Reconstruction, np.ndarray | None]:
    """A result file as a :class:`~gaitcap.reconstruction.result.Reconstruction` (sampled as it was computed when it holds dense samples) and
    its per-point reprojection error (T, J) px, or None. Also reads the older files: the worker's (no
    method, cameras or dense samples) and ``gaitcap reconstruct``'s (``quality`` for the agreeing views)."""
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    with np.load(path, allow_pickle=False) as data:
        missing = [k for k in ("points_mm", "times_s", "joint_names") if k not in data.files]
        if missing:
            raise ValueError(f"{path}: missing array(s) {', '.join(missing)} (need points_mm, times_s, "
                             "joint_names)")
        points, times = data["points_mm"], data["times_s"]
        names = tuple(str(n) for n in data["joint_names"])
        views = next((data[k] for k in ("num_views", "quality")  # "quality": effective agreeing views
                      if k in data.files and data[k].shape == points.shape[:2]), None)
        reproj = data["reprojection_px"] if views is not None and "reprojection_px" in data.files else None
        sample = _dense_sampler_of(path, data, num_joints=len(names))
        method = str(data["method"]) if "method" in data.files else path.name
        cameras = tuple(str(n) for n in data["camera_names"]) if "camera_names" in data.files else ()
    return Reconstruction(method, points, times, names, camera_names=cameras, quality=views,
                          trajectory=sample), reproj


def _dense_sampler_of(path: Path, data, *, num_joints: int):
    if "dense_times_s" not in data.files or "dense_points_mm" not in data.files:
        return None
    grid, dense = data["dense_times_s"], data["dense_points_mm"]
    if grid.ndim != 1 or len(grid) < 2 or dense.shape != (len(grid), num_joints, 3):
        raise ValueError(f"{path}: dense_points_mm {dense.shape} does not match dense_times_s {grid.shape} "
                         f"and {num_joints} joints (expected ({len(grid)}, {num_joints}, 3))")
    return spline_sampler(grid, dense)


def report_png(traj: Reconstruction, report, *, title: str) -> bytes:
    """The gait module's heel-trace plot when there is a report; else heel height and position over
    time for both feet (so a trial without steps still shows what was measured)."""
    if report is not None:
        from gaitcap.services.processing.report_plot import heel_traces_png

        return heel_traces_png(report, traj.points_mm, traj.times_s, list(traj.joint_names))
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 5.5), dpi=100)
    ax_h, ax_x = fig.subplots(2, 1, sharex=True)
    colors = {"left": "#1f77b4", "right": "#d62728"}
    for side, color in colors.items():
        name = f"{side}_heel"
        if name not in traj.joint_names:
            continue
        heel = traj.points_mm[:, traj.joint_names.index(name)]
        ax_h.plot(traj.times_s, heel[:, 2], color=color, lw=1.2, label=f"{side} heel")
        ax_x.plot(traj.times_s, heel[:, 0], color=color, lw=1.2, label=f"{side} heel x")
        ax_x.plot(traj.times_s, heel[:, 1], color=color, lw=1.0, ls="--", label=f"{side} heel y")
        if report is not None:
            strikes = [s.heel_strike_s for s in report.steps if s.foot == side]
            z = np.interp(strikes, traj.times_s, np.nan_to_num(heel[:, 2])) if strikes else []
            ax_h.plot(strikes, z, "v", color=color, ms=7, label=f"{side} heel strikes")
    ax_h.set_ylabel("heel height (mm)")
    ax_x.set_ylabel("heel position (mm)")
    ax_x.set_xlabel("time (s)")
    ax_h.legend(loc="upper right", fontsize=8, ncol=2)
    ax_x.legend(loc="upper right", fontsize=7, ncol=2)
    ax_h.set_title(title, fontsize=11)
    for ax in (ax_h, ax_x):
        ax.grid(alpha=0.3)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()


def write_data(files: TrialFiles, stage: str, traj: Reconstruction, report, *,
               data_quality: dict | None = None, consistency: dict | None = None) -> dict[str, str]:
    """The stage's trajectory (npz) and gait report (JSON, steps CSV, per-side summary CSV): quick, written
    before the result is stored in the catalog; artifact key -> path of each file written. ``data_quality``
    (the trial's measures and plain-word warnings, :class:`~gaitcap.services.processing.quality.DataQuality`
    as a dict) goes into gait.json beside the gait analysis's own warnings, so the file never carries
    numbers without their quality; ``consistency`` (the stage's consistency rules,
    :func:`~gaitcap.services.processing.checks.stage_consistency`) beside them, so a failed rule travels with
    the numbers it puts in doubt."""
    write_npz(files.stage_file(stage, "trajectory_npz"), traj)
    written = ["trajectory_npz"]
    if report is not None:
        payload = {**report.to_dict(), **({"data_quality": data_quality} if data_quality is not None else {}),
                   **({"consistency": consistency} if consistency is not None else {})}
        atomic_write_text(files.stage_file(stage, "gait_json"), json.dumps(json_ready(payload), indent=2) + "\n")
        atomic_write_text(files.stage_file(stage, "steps_csv"), report.to_csv())
        atomic_write_text(files.stage_file(stage, "summary_csv"), report.to_summary_csv())
        written += ["gait_json", "steps_csv", "summary_csv"]
    return {k: str(files.stage_file(stage, k)) for k in written}


def write_views(files: TrialFiles, stage: str, traj: Reconstruction, report, *, trial_id: str) -> dict[str, str]:
    """The TRC export and the report plot (slower; written right after the result is stored); artifact
    key -> path of each."""
    from gaitcap.reconstruction.trc import to_trc

    trc = to_trc(traj.points_mm, traj.times_s, traj.joint_names, filename=f"{trial_id}-{stage}.trc")
    atomic_write_bytes(files.stage_file(stage, "trajectory_trc"), trc.encode())
    title = f"Trial {trial_id}: {stage} ({traj.method})"
    atomic_write_bytes(files.stage_file(stage, "report_png"), report_png(traj, report, title=title))
    return {k: str(files.stage_file(stage, k)) for k in ("trajectory_trc", "report_png")}
