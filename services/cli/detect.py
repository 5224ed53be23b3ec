"""``gaitcap detect --videos DIR --detector mediapipe|onnx [--model PATH] --out KEYPOINTS.npz``."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import typer
from gaitcap.services.cli._common import progress, user_errors


def _params(items: list[str]) -> dict:
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise ValueError(f"--param: expected KEY=VALUE, got {item!r}")
        try:
            out[key] = json.loads(value)
        except json.JSONDecodeError:
            out[key] = value
    return out


def register(app: typer.Typer) -> None:
    @app.command("detect")
    def detect_cmd(
        videos: Path = typer.Option(..., "--videos", help="Folder with one video file per camera (camera = file stem)."),
        detector: str = typer.Option("mediapipe", "--detector", help="Detector kind: mediapipe | onnx."),
        model: Path | None = typer.Option(None, "--model", help="Model file (onnx: the .onnx top-down model)."),
        param: list[str] = typer.Option([], "--param", help="Other detector config field KEY=VALUE."),
        fps: float | None = typer.Option(None, "--fps", help="Frame rate (default: the files')."),
        out: Path = typer.Option(..., "--out", help="Output keypoints .npz (the reconstruction's input)."),
        all_people: Path | None = typer.Option(None, "--all-people", help="Also write every person (C,T,P,J,3) here."),
    ) -> None:
        """2D keypoints of existing multi-view videos -> NPZ for `gaitcap reconstruct` / `associate`."""
        import gaitcap.acquisition.detectors  # noqa: F401  (registers the detector kinds)
        from gaitcap.acquisition.detectors.base import config_class
        from gaitcap.acquisition.drivers.video import VideoCamera
        from gaitcap.acquisition.video_detect import detect_videos, find_videos
        from gaitcap.reconstruction.association.multi import MultiPersonDetections
        from gaitcap.reconstruction.association.npz_io import save_detections_npz

        with user_errors():
            files = find_videos(videos)
            cls = config_class(detector)
            params = _params(param)
            fields = {f.name for f in dataclasses.fields(cls)}
            if model is not None:
                key = "model_path" if "model_path" in fields else "model"
                if key not in fields:
                    raise ValueError(f"--model: detector {detector} takes no model file")
                params[key] = model if key == "model_path" else str(model)
            det = cls(**params).build()
            total = 0
            for f in files:
                cam = VideoCamera(f, realtime=False)
                cam.open()
                total += cam.frame_count or 0
                cam.close()
            with progress(total=total or None, desc="detect", unit="frame") as bar:
                result = detect_videos(files, det, fps=fps, on_frame=lambda: bar.update(1))
            patient = result.patient()
            save_detections_npz(patient, out)
            if all_people is not None:
                from gaitcap.reconstruction.association.npz_io import save_multi_npz

                save_multi_npz(MultiPersonDetections(result.people, result.camera_names, result.times_s,
                                                     result.skeleton), all_people)
        seen = float((patient.keypoints[..., 2] > 0.5).mean())
        typer.echo(f"{out}: {len(files)} cameras x {patient.shape[1]} frames ({result.fps:g} fps), "
                   f"{patient.skeleton.name}, {100 * seen:.0f} % keypoints with confidence > 0.5")
