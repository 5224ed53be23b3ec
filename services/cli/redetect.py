"""``gaitcap redetect TRIAL.mcap... --detector KIND [--model PATH] --out DIR``: stored trials' keypoints again,
from their recorded images, with another detector (or only the frames the live pass missed). One trial: its
frames over a pool of detector processes, files into DIR; several: one trial per task on a local process
pool (or a Ray cluster, ``--ray``), files into DIR/<trial>."""

from __future__ import annotations

import json
from pathlib import Path

import typer
from gaitcap.services.cli._common import progress, user_errors


def _describe(kind: str, model: Path | None, param: list[str]) -> str:
    return " ".join([kind, *([str(model)] if model is not None else []), *param])


def _executor(ray: str, workers: int):
    from gaitcap.services.research.executors import Inline, LocalPool, RayCluster

    if ray:
        return RayCluster(address=ray, local_cpus=workers or None)
    return Inline() if workers == 0 else LocalPool(workers=workers)


def register(app: typer.Typer) -> None:
    @app.command("redetect")
    def redetect_cmd(
        trials: list[Path] = typer.Argument(..., help="The trials' recordings (MCAP)."),
        detector: str = typer.Option("mediapipe", "--detector", help="Detector kind: mediapipe | onnx."),
        model: Path | None = typer.Option(None, "--model", help="Model: mediapipe lite|full|heavy or a .tflite; "
                                          "onnx: the .onnx top-down model."),
        param: list[str] = typer.Option([], "--param", help="Other detector config field KEY=VALUE."),
        out: Path = typer.Option(..., "--out", help="Folder for keypoints_complete.npz and completion.json "
                                 "(several trials: one sub-folder per trial)."),
        workers: int | None = typer.Option(None, "--workers", help="Processes (default: one per CPU core): "
                                           "detector processes for one trial, trials at once for several."),
        ray: str = typer.Option("", "--ray", help="Several trials on a Ray cluster: its address (auto for the "
                                "local one)."),
        only_missing: bool = typer.Option(
            False, "--only-missing", help="Keep the live keypoints; detect only the recorded frames without any."),
    ) -> None:
        """Detect every recorded frame of stored trials again (or only the missing ones) -> keypoints + report."""
        from gaitcap.acquisition.detectors.pool import default_workers
        from gaitcap.services.cli.detect import detector_config
        from gaitcap.services.processing.completion import CompletionSettings

        with user_errors():
            settings = CompletionSettings(detector_config(detector, model, param),
                                          workers=workers or default_workers(), redetect_all=not only_missing)
            if len(trials) == 1 and not ray:
                _one(trials[0], out, settings, only_missing, _describe(detector, model, param))
            else:
                _many(trials, out, settings, only_missing, ray, default_workers() if workers is None else workers)


def _one(trial: Path, out: Path, settings, only_missing: bool, name: str) -> None:
    from gaitcap.acquisition.detectors.pool import shared_cores
    from gaitcap.acquisition.recording.reader import read_keypoints, resolve_recording
    from gaitcap.services.processing.completion import complete_keypoints, save_completion

    path = resolve_recording(trial)
    live = _live_keypoints(path, read_keypoints) if only_missing else None
    kp, report = complete_keypoints(path, live, shared_cores(settings.detector, settings.workers).build, detector_name=name,
                                    workers=settings.workers, redetect_all=not only_missing)
    files = save_completion(out, kp, report)
    frames = report.to_dict()["frames"]
    typer.echo(f"{files.keypoints}: {len(kp.camera_names)} cameras x {kp.frame_ids.size} frames, {kp.skeleton.name}; "
               f"{frames['recorded']} recorded, {frames['live']} live, {frames['completed']} detected, "
               f"{frames['corrupt']} corrupt in {report.seconds:.1f} s")
    typer.echo(f"{files.report}: " + json.dumps({c: {k: v for k, v in row.items() if k in ("coverage", "corrupt")}
                                                  for c, row in report.to_dict()["cameras"].items()}))


def _many(trials: list[Path], out: Path, settings, only_missing: bool, ray: str, workers: int) -> None:
    from gaitcap.services.research.redetect import plan_redetect, run_redetect

    tasks = plan_redetect(trials, out, settings, only_missing=only_missing)
    with _executor(ray, workers).open() as executor, progress(len(tasks), "redetect", "trial") as bar:
        def on_outcome(outcome) -> None:
            bar.update(1)
            if outcome.status == "failed":
                bar.write(f"failed: {outcome.mcap}: {outcome.error}")

        outcomes = run_redetect(tasks, executor, on_outcome=on_outcome)
    for o in outcomes:
        words = (f"{o.report['frames']['completed']} frames detected, {o.report['frames']['corrupt']} corrupt"
                 if o.status == "done" else o.error)
        typer.echo(f"{o.out_dir}: {o.status}: {words}")
    failed = sum(o.status == "failed" for o in outcomes)
    if failed:
        raise typer.Exit(1)


def _live_keypoints(path: Path, read_keypoints):
    try:
        return read_keypoints(path)
    except ValueError as exc:
        if "no keypoints recorded" not in str(exc):
            raise
        return None  # nothing was detected live: every frame is detected now
