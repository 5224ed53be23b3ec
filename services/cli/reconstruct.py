"""``gaitcap reconstruct``: 3D trajectories from 2D keypoints and a calibration."""

from __future__ import annotations

import enum
import json
from pathlib import Path

import typer
from gaitcap.acquisition.fileio import atomic_write_text
from gaitcap.reconstruction.jsonable import json_ready
from gaitcap.services.cli._common import progress, user_errors


class MethodName(enum.StrEnum):
    dlt = "dlt"
    robust = "robust"
    explicit = "explicit"
    implicit = "implicit"


def _method(name: MethodName, paper: bool, steps: int | None):
    from gaitcap.reconstruction.methods import METHODS

    cls = METHODS[name.value]
    if paper:
        if not hasattr(cls, "paper"):
            raise ValueError(f"--paper: the {name.value} method has no paper configuration (fits only)")
        return cls.paper() if steps is None else cls.paper(steps=steps)
    if steps is not None:
        raise ValueError("--steps: only with --paper")
    return cls()


def patient_request(person: int | None, patient_near: str | None):
    """``--person N`` / ``--patient-near X,Y`` as a :class:`~gaitcap.services.processing.offline.PatientRequest`."""
    from gaitcap.services.processing.offline import PatientRequest

    near = None
    if patient_near is not None:
        parts = [p for p in patient_near.replace(" ", "").split(",") if p]
        if len(parts) != 2:
            raise ValueError(f"--patient-near: expected X,Y in mm (a floor point), got {patient_near!r}")
        near = (float(parts[0]), float(parts[1]))
    return PatientRequest(track_id=person, near_mm=near)


def figure(value, fmt: str = ".3f", why: str = "not measurable") -> str:
    """A number for the terminal, or ``n/a (why)`` instead of NaN."""
    import math

    return f"{value:{fmt}}" if value is not None and math.isfinite(value) else f"n/a ({why})"


def reconstruct_command(
    calibration: Path | None = typer.Option(
        None, "--calibration", help="aniposelib/Pose2Sim TOML or gaitcap JSON (default: the input's own)."),
    keypoints: Path = typer.Option(..., "--keypoints", help="NPZ, trial MCAP, OpenPose/MMPose JSON, or a Pose2Sim, "
                                   "anipose or FreeMoCap folder."),
    method: MethodName = typer.Option(MethodName.implicit, "--method", help="Reconstruction method."),
    out: Path = typer.Option(..., "--out", help="Result NPZ, the worker's format (points_mm, times_s, joint_names, method, ...)."),
    trc: Path | None = typer.Option(None, "--trc", help="Also write an OpenSim TRC file."),
    as_json: bool = typer.Option(False, "--json", help="Print the metrics as one JSON object."),
    paper: bool = typer.Option(False, "--paper", help="The paper's configuration (explicit/implicit; slow)."),
    steps: int | None = typer.Option(None, "--steps", help="Steps of the --paper configuration."),
    fps: float = typer.Option(30.0, "--fps", help="Frame rate when the input has no times."),
    skeleton: str | None = typer.Option(None, "--skeleton", help="Keypoint layout (default: the input's, else "
                                        "recognised from the keypoints)."),
    person: int | None = typer.Option(None, "--person", help="Several people in view: this track id is the patient."),
    patient_near: str | None = typer.Option(
        None, "--patient-near", help="Several people in view: the one nearest this floor point X,Y mm early on."),
) -> None:
    """Reconstruct 3D keypoint trajectories (mm) from multi-camera 2D keypoints (the one processing path,
    its reconstruction stage only: no gait files, no kinematics)."""
    with user_errors():
        from gaitcap.reconstruction.trc import to_trc
        from gaitcap.services.processing.offline import (
            OfflineOptions,
            choice_reason,
            load_input,
            people_lines,
        )
        from gaitcap.services.processing.outputs import write_npz
        from gaitcap.services.processing.trial import StagePlan, TrialOptions, ViewerFiles, process_trial

        options = OfflineOptions(skeleton=skeleton, fps=fps, patient=patient_request(person, patient_near))
        data = load_input(keypoints, calibration=calibration, options=options)
        plan = TrialOptions(stages=(StagePlan(method.value, _method(method, paper, steps)),),
                            selector=options.patient.selector(), kinematics=False, viewer_files=ViewerFiles.NONE)
        with progress(desc=method.value, unit="step") as bar:

            def report(done: int, total: int) -> None:
                bar.total = total
                bar.n = done
                bar.refresh()

            result = process_trial(data, plan, files=None, fit_progress=report)
        if result.selection is not None:
            typer.echo(f"{result.selection.tracks.num_tracks} people tracked:", err=True)
            for line in people_lines(result.selection, how=choice_reason(options.patient)):
                typer.echo(f"  {line}", err=True)
        for warning in result.quality.warnings:  # the data's problems and the checks' (a mix of two people, ...)
            typer.echo(f"data quality: {warning}", err=True)
        rec, layout = result.last.reconstruction, result.layout
        write_npz(out, result.last.trajectory)  # the worker's result file (dense samples of a fit included)
        if trc is not None:
            atomic_write_text(trc, to_trc(rec.points_mm, rec.times_s, rec.joint_names, filename=trc.name))
    from gaitcap.services.processing.offline import frame_ranges, missing_by_joint

    missing = missing_by_joint(rec.points_mm, rec.joint_names)
    if as_json:
        typer.echo(json.dumps(json_ready({"method": rec.method, **rec.metrics, "losses": rec.losses,
                                          "layout": layout.skeleton, "layout_evidence": layout.evidence()})))
    else:
        m = rec.metrics
        typer.echo(f"{layout.evidence()}")
        typer.echo(
            f"{rec.method}: {rec.points_mm.shape[0]} frames x {rec.points_mm.shape[1]} joints -> {out}; "
            f"GC_5 {figure(m['GC_5'])} GC_10 {figure(m['GC_10'])} GC_20 {figure(m['GC_20'])} "
            f"L_reproj {figure(m['L_reproj'], '.2f')} L_smooth {figure(m['L_smooth'], '.2f')} mm "
            f"L_skeleton {figure(m['L_skeleton'], '.2f')} mm"
        )
    if missing:
        typer.echo("note: joints missing in some frames (NaN in the file): " + "; ".join(
            f"{n} frames {frame_ranges(frames)}" for n, frames in missing.items()), err=True)


def register(app: typer.Typer) -> None:
    app.command("reconstruct")(reconstruct_command)
