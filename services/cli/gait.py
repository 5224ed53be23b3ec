"""``gaitcap gait RESULT.npz``: gait events and spatiotemporal parameters of a reconstructed trial."""

from __future__ import annotations

import math
from pathlib import Path

import typer
from gaitcap.services.cli._common import user_errors

_TABLE = ("step_length_mm", "stride_length_mm", "step_width_mm", "step_time_s", "stride_time_s",
          "stance_pct", "swing_pct", "double_support_pct")


def _pick_trial(trials, result: Path):
    if len(trials) == 1:
        return trials[0]
    named = [t for t in trials if t.name == result.stem]
    if not named:
        raise ValueError(f"walkway CSV holds trials {[t.name for t in trials]}; none is named {result.stem!r}")
    return named[0]


def _fmt(x: float, digits: int = 1) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x:.{digits}f}"


def _echo_summary(report) -> None:
    s = report.summary
    typer.echo(f"steps {s.num_steps} in {s.num_passes} pass(es); cadence {_fmt(s.cadence_steps_min)} "
               f"steps/min; gait speed {_fmt(s.gait_speed_m_s, 2)} m/s")
    t = report.timing
    if t is not None:
        typer.echo(f"events located on the {t.located_on}: resolution {t.resolution_s * 1000:.0f} ms "
                   f"({'sub-frame' if t.sub_frame else 'one frame'}; frames {t.frame_interval_s * 1000:.1f} ms apart)")
    typer.echo(f"{'parameter':<20}{'left mean':>11}{'SD':>8}{'right mean':>12}{'SD':>8}{'asym %':>8}")
    for name in _TABLE:
        p, d = s.parameters[name], 3 if name.endswith("_s") else 1
        typer.echo(f"{name:<20}{_fmt(p['left'].mean, d):>11}{_fmt(p['left'].sd, d):>8}"
                   f"{_fmt(p['right'].mean, d):>12}{_fmt(p['right'].sd, d):>8}{_fmt(s.asymmetry_pct[name]):>8}")
    if report.walkway is not None:
        w = report.walkway
        typer.echo(f"walkway: scale {w.transform.scale:.4f}, offsets "
                   + ", ".join(f"{k} {v:+.2f} s" for k, v in w.offsets_s.items()))
        typer.echo(f"{'residual (mm)':<20}{'n':>5}{'mean':>8}{'SD':>8}{'RMSE':>8}{'sigma_IQR':>11}")
        for name, r in w.residuals.items():
            typer.echo(f"{name:<20}{r.n:>5}{_fmt(r.mean):>8}{_fmt(r.sd):>8}{_fmt(r.rmse):>8}"
                       f"{_fmt(r.sigma_iqr):>11}")
    for warning in report.warnings:
        typer.echo(f"note: {warning}", err=True)


def register(app: typer.Typer) -> None:
    @app.command("gait")
    def gait(
        result: Path = typer.Argument(..., help="Result NPZ (reconstruct, process, the worker's "
                                     "trajectory.npz) or any NPZ with points_mm, times_s, joint_names."),
        walkway: Path | None = typer.Option(None, "--walkway", help="Walkway export CSV to compare with."),
        as_json: bool = typer.Option(False, "--json", help="Print the report as one JSON object."),
        csv_path: Path | None = typer.Option(None, "--csv", help="Write one CSV row per step to FILE."),
        plot_path: Path | None = typer.Option(None, "--plot", help="Write a PNG of the heel traces to FILE."),
    ) -> None:
        """Gait events, bouts and spatiotemporal parameters of a reconstructed trial."""
        from gaitcap.acquisition.fileio import atomic_write_bytes, atomic_write_text
        from gaitcap.acquisition.readers import read_walkway_csv
        from gaitcap.reconstruction.gait import GaitConfig, compare_with_walkway
        from gaitcap.services.processing.outputs import read_npz
        from gaitcap.services.processing.pipeline import gait_of
        from gaitcap.services.processing.report_plot import heel_traces_png

        with user_errors():
            traj, reproj = read_npz(result)
            points, times, names = traj.points_mm, traj.times_s, list(traj.joint_names)
            config = GaitConfig()
            report, problem = gait_of(traj, reprojection_px=reproj)  # the worker's gait analysis
            if report is None:
                raise ValueError(f"{result}: no gait parameters: {problem}")
            if walkway is not None:
                trial = _pick_trial(read_walkway_csv(walkway), result)
                report = report.with_walkway(
                    compare_with_walkway([(points, times, names)], [trial], config=config))
            if csv_path is not None:
                atomic_write_text(csv_path, report.to_csv())
            if plot_path is not None:
                atomic_write_bytes(plot_path, heel_traces_png(report, points, times, names, config=config))
        if as_json:
            typer.echo(report.to_json())
        else:
            _echo_summary(report)
