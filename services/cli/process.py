"""``gaitcap process INPUT --out DIR``: from recordings to a gait report in one command, through the
worker's processing path (:mod:`gaitcap.services.processing.offline`)."""

from __future__ import annotations

import json
from pathlib import Path

import typer
from gaitcap.services.cli._common import progress, user_errors
from gaitcap.services.cli.detect import COMPLETE_WITH_HELP, ONLY_MISSING_HELP, completion_plan


def _echo_summary(result, out: Path, chosen_how: str) -> None:
    from gaitcap.services.cli.reconstruct import figure

    typer.echo(f"{result.source}: {len(result.cameras)} cameras ({', '.join(result.cameras)}), {result.frames} frames")
    if result.layout is not None:
        typer.echo(result.layout.evidence())
        for warning in result.layout.warnings:
            typer.echo(f"warning: {warning}", err=True)
    if result.selection is not None:
        from gaitcap.services.processing.offline import people_lines

        typer.echo(f"{result.selection.tracks.num_tracks} people tracked (see {out / 'people.json'}):")
        for line in people_lines(result.selection, how=chosen_how):
            typer.echo(f"  {line}")
    for name, stage in result.stages.items():
        from gaitcap.services.processing.offline import missing_frames

        s = stage.report.summary if stage.report is not None else None
        if s is None:
            typer.echo(f"{name} ({stage.trajectory.method}): no gait parameters: {stage.problem}")
        else:
            typer.echo(f"{name} ({stage.trajectory.method}): {s.num_steps} steps, cadence "
                       f"{figure(s.cadence_steps_min, '.1f', 'too few steps')} steps/min, gait speed "
                       f"{figure(s.gait_speed_m_s, '.2f', 'no straight pass')} m/s")
        if stage.missing:
            typer.echo("  joints missing in some frames (NaN in the files): "
                       + "; ".join(f"{j} frames {r}" for j, r in missing_frames(stage.trajectory).items()))
        typer.echo(f"  files: {out / name}/ ({', '.join(sorted(Path(p).name for p in stage.files.values()))})")
    for warning in result.quality.warnings:
        typer.echo(f"data quality: {warning}", err=True)
    typer.echo("time: " + ", ".join(f"{k} {v:.1f} s" for k, v in result.timings_s.items()))


def _kinematics(out: Path, result) -> str:
    """Where the last stage's kinematics are, or why there are none (its kinematics.json says)."""
    from gaitcap.services.processing.artifacts import TrialFiles

    stage = result.last.name
    path = TrialFiles(out).stage_file(stage, "kinematics_json")
    status = json.loads(path.read_text()) if path.is_file() else {"available": False, "reason": "not written"}
    if status.get("available"):
        return f"kinematics ({stage}): {path.parent}/ (kinematics.mot, .osim, .trc, .json, .csv, trajectory.c3d)"
    return f"kinematics ({stage}) unavailable: {status.get('reason', '')}"


def register(app: typer.Typer) -> None:
    @app.command("process")
    def process_cmd(
        source: Path = typer.Argument(..., help="A folder of videos (one per camera), a trial MCAP, keypoints (NPZ, "
                                      "OpenPose/MMPose JSON) or a Pose2Sim, anipose or FreeMoCap folder."),
        out: Path = typer.Option(..., "--out", help="Output folder: <stage>/trajectory.npz|.trc, gait.json, steps.csv, "
                                 "report.png, trajectory.rrd, results.mcap; people.json with several people."),
        calibration: Path | None = typer.Option(
            None, "--calibration", help="Calibration TOML/JSON (default: the one the input carries)."),
        skeleton: str | None = typer.Option(None, "--skeleton", help="Keypoint layout (default: the input's, else "
                                            "recognised from the keypoints)."),
        person: int | None = typer.Option(None, "--person", help="Several people in view: this track is the patient."),
        patient_near: str | None = typer.Option(
            None, "--patient-near", help="Several people in view: the one nearest floor point X,Y mm early on."),
        detector: str = typer.Option("mediapipe", "--detector", help="Videos: detector kind (mediapipe | onnx)."),
        model: Path | None = typer.Option(None, "--model", help="Videos: the detector's model file."),
        param: list[str] = typer.Option([], "--param", help="Videos: other detector config field KEY=VALUE."),
        fps: float = typer.Option(30.0, "--fps", help="Frame rate when the input has none."),
        refine: bool = typer.Option(True, "--refine/--no-refine", help="Also run the implicit fit (slower)."),
        complete_with: str = typer.Option("none", "--complete-with", help="A trial MCAP: " + COMPLETE_WITH_HELP),
        complete_model: Path | None = typer.Option(None, "--complete-model", help="Its model."),
        complete_param: list[str] = typer.Option([], "--complete-param", help="Its other config field KEY=VALUE."),
        complete_workers: int | None = typer.Option(None, "--complete-workers", help="Its processes."),
        complete_only_missing: bool = typer.Option(False, "--complete-only-missing", help=ONLY_MISSING_HELP),
        kinematics: bool = typer.Option(True, "--kinematics/--no-kinematics",
                                        help="Joint kinematics of the last stage (OpenSim model fit)."),
        as_json: bool = typer.Option(False, "--json", help="Print the summary as one JSON object."),
    ) -> None:
        """Detection (videos) -> association -> reconstruction -> gait -> files, as the worker does."""
        import time

        from gaitcap.reconstruction.jsonable import json_ready
        from gaitcap.services.cli.detect import build_detector
        from gaitcap.services.cli.reconstruct import patient_request
        from gaitcap.services.processing.offline import (
            OfflineOptions,
            choice_reason,
            load_input,
            process_input,
            result_summary,
        )

        with user_errors():
            options = OfflineOptions(skeleton=skeleton, fps=fps, refine=refine,
                                     patient=patient_request(person, patient_near), kinematics=kinematics,
                                     completion=completion_plan(complete_with, complete_model, complete_param,
                                                                complete_workers, only_missing=complete_only_missing))
            t0 = time.perf_counter()
            with progress(desc="detect", unit="frame") as bar:
                data = load_input(source, calibration=calibration, options=options,
                                       detector_factory=lambda: build_detector(detector, model, param),
                                       on_frame=lambda: bar.update(1))
            read_s = time.perf_counter() - t0
            with progress(desc="steps", unit="step") as stages, progress(desc="fit", unit="step") as fit:

                def on_stage(name: str) -> None:
                    stages.set_description(name)
                    stages.update(1)

                def on_fit(done: int, total: int) -> None:
                    fit.total, fit.n = total, done
                    fit.refresh()

                result = process_input(data, out, options=options, on_stage=on_stage, fit_progress=on_fit,
                                       timings_s={"read and detect": read_s})
            kinematics_note = _kinematics(out, result) if kinematics else ""
            chosen_how = choice_reason(options.patient)
        if as_json:
            typer.echo(json.dumps(json_ready(result_summary(result, chosen_how=chosen_how))))
        else:
            _echo_summary(result, out, chosen_how)
            if kinematics_note:
                typer.echo(kinematics_note)
