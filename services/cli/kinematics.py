"""``gaitcap kinematics RESULT.npz``: an OpenSim model fitted to a reconstructed trial, its joint angles over
the gait cycle (mean +- SD per side, key clinical values, normal-gait bands) and the exports."""

from __future__ import annotations

import json
import math
from pathlib import Path

import typer
from gaitcap.services.cli._common import user_errors

_KEYS = ("knee_flexion_initial_contact_deg", "knee_peak_flexion_swing_deg", "ankle_peak_dorsiflexion_stance_deg",
         "hip_minimum_terminal_stance_deg", "hip_flexion_rom_deg", "knee_flexion_rom_deg", "ankle_rom_deg")


def _fmt(stats: dict) -> str:
    m, sd = stats.get("mean"), stats.get("sd")
    if m is None or not math.isfinite(m):
        return "-"
    return f"{m:.1f}" + (f" +- {sd:.1f}" if sd is not None else "")


def _echo_summary(d: dict, out: Path) -> None:
    n = {side: d["curves"]["knee_flexion"][side]["n_cycles"] for side in ("left", "right")}
    typer.echo(f"gait cycles: left {n['left']}, right {n['right']}; model {d['model']['setup']} "
               f"({d['model']['frames_fitted']} of {d['model']['frames']} frames fitted, scale "
               f"{d['model']['seconds']['scale']:.1f} s, IK {d['model']['seconds']['ik']:.1f} s)")
    typer.echo(f"{'key value (deg)':<42}{'left':>16}{'right':>16}")
    for key in _KEYS:
        typer.echo(f"{key:<42}{_fmt(d['key_values']['left'][key]):>16}{_fmt(d['key_values']['right'][key]):>16}")
    errs = d["marker_errors_mm"]
    if errs:
        worst = max(errs, key=lambda m: errs[m]["rms"])
        mean_rms = sum(e["rms"] for e in errs.values()) / len(errs)
        typer.echo(f"marker error RMS: mean {mean_rms:.1f} mm over {len(errs)} markers, worst {worst} "
                   f"{errs[worst]['rms']:.1f} mm (max {errs[worst]['max']:.1f} mm)")
    if d["norms"]["bands"]:
        typer.echo(f"normal-gait band: {d['norms']['population']}")
    elif d["norms"].get("no_reference"):
        typer.echo(f"normal-gait band: {d['norms']['no_reference']}")
    else:
        typer.echo("note: normal-gait bands not installed (run deploy/bootstrap.sh)", err=True)
    for warning in d.get("warnings") or []:
        typer.echo(f"warning: {warning}", err=True)
    typer.echo(f"files: {out}/ (kinematics.mot, .osim, .trc, .json, .csv, trajectory.c3d)")


def register(app: typer.Typer) -> None:
    @app.command("kinematics")
    def kinematics(
        result: Path = typer.Argument(..., help="NPZ with points_mm (T,J,3), times_s (T,), joint_names (J,)."),
        out: Path | None = typer.Option(None, "--out", help="Output folder (default: RESULT's folder / "
                                        "<name>-kinematics)."),
        mass_kg: float = typer.Option(70.0, "--mass-kg", help="The patient's mass (inertia only)."),
        age: int | None = typer.Option(None, "--age", metavar="YEARS", help="The patient's age at the trial "
                                       "(years): chooses the normal-gait band (children's under 18, adults' "
                                       "18-65); without it, or outside those ages: no band."),
        as_json: bool = typer.Option(False, "--json", help="Print the kinematics report as one JSON object."),
    ) -> None:
        """Scale an OpenSim model to the trial, inverse kinematics, gait-cycle joint angles with norms."""
        from gaitcap.services.kinematics import KinematicsUnavailable
        from gaitcap.services.kinematics.trial import FILES, KinematicsConfig, trial_kinematics
        from gaitcap.services.processing.outputs import read_npz
        from gaitcap.services.processing.pipeline import gait_of

        folder = out or result.with_name(f"{result.stem}-kinematics")
        with user_errors():
            if not math.isfinite(mass_kg) or not 20.0 <= mass_kg <= 300.0:
                raise ValueError(f"--mass-kg: must be in [20, 300], got {mass_kg}")
            if age is not None and not 0 <= age <= 120:
                raise ValueError(f"--age: must be in [0, 120] years, got {age}")
            traj, reproj = read_npz(result)
            gait, problem = gait_of(traj, reprojection_px=reproj)  # the worker's gait analysis
            if gait is None:
                typer.echo(f"note: no gait cycles ({problem}); joint angles only", err=True)
            try:
                trial_kinematics(traj.points_mm, traj.times_s, traj.joint_names,
                                 steps=gait.steps if gait is not None else (), quality=traj.quality,
                                 out_dir=folder, age_years=age, config=KinematicsConfig(mass_kg=mass_kg))
            except KinematicsUnavailable as exc:
                typer.echo(f"error: kinematics are unavailable: {exc}", err=True)
                raise typer.Exit(code=3) from None
        shown = json.loads((folder / FILES["json"]).read_text())  # what is shown is the file as written
        if as_json:
            typer.echo(json.dumps(shown))
        else:
            _echo_summary(shown, folder)
