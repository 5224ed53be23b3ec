"""``gaitcap redetect TRIAL.mcap --detector KIND [--model PATH] --out DIR``: a stored trial's keypoints again,
from its recorded images, with another detector (or only the frames the live pass missed)."""

from __future__ import annotations

import json
from pathlib import Path

import typer
from gaitcap.services.cli._common import user_errors


def _describe(kind: str, model: Path | None, param: list[str]) -> str:
    return " ".join([kind, *([str(model)] if model is not None else []), *param])


def register(app: typer.Typer) -> None:
    @app.command("redetect")
    def redetect_cmd(
        trial: Path = typer.Argument(..., help="The trial's recording (MCAP)."),
        detector: str = typer.Option("mediapipe", "--detector", help="Detector kind: mediapipe | onnx."),
        model: Path | None = typer.Option(None, "--model", help="Model: mediapipe lite|full|heavy or a .tflite; "
                                          "onnx: the .onnx top-down model."),
        param: list[str] = typer.Option([], "--param", help="Other detector config field KEY=VALUE."),
        out: Path = typer.Option(..., "--out", help="Folder for keypoints_complete.npz and completion.json."),
        workers: int | None = typer.Option(None, "--workers", help="Detector processes (default: one per CPU core)."),
        only_missing: bool = typer.Option(
            False, "--only-missing", help="Keep the live keypoints; detect only the recorded frames without any."),
    ) -> None:
        """Detect every recorded frame of a stored trial again (or only the missing ones) -> keypoints + report."""
        from gaitcap.acquisition.detectors.pool import default_workers
        from gaitcap.acquisition.recording.reader import read_keypoints, resolve_recording
        from gaitcap.services.cli.detect import detector_config
        from gaitcap.services.processing.completion import complete_keypoints, save_completion

        with user_errors():
            path = resolve_recording(trial)
            config = detector_config(detector, model, param)
            live = _live_keypoints(path, read_keypoints) if only_missing else None
            kp, report = complete_keypoints(path, live, config.build, detector_name=_describe(detector, model, param),
                                            workers=workers or default_workers(), redetect_all=not only_missing)
            files = save_completion(out, kp, report)
        frames = report.to_dict()["frames"]
        typer.echo(f"{files.keypoints}: {len(kp.camera_names)} cameras x {kp.frame_ids.size} frames, {kp.skeleton}; "
                   f"{frames['recorded']} recorded, {frames['live']} live, {frames['completed']} detected, "
                   f"{frames['corrupt']} corrupt in {report.seconds:.1f} s")
        typer.echo(f"{files.report}: " + json.dumps({c: {k: v for k, v in row.items() if k in ("coverage", "corrupt")}
                                                      for c, row in report.to_dict()["cameras"].items()}))


def _live_keypoints(path: Path, read_keypoints):
    try:
        return read_keypoints(path)
    except ValueError as exc:
        if "no keypoints recorded" not in str(exc):
            raise
        return None  # nothing was detected live: every frame is detected now
