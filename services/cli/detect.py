"""``gaitcap detect --videos DIR --detector mediapipe|onnx [--model PATH] --out KEYPOINTS.npz``."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import typer
from gaitcap.services.cli._common import key_values, progress, user_errors


def build_detector(kind: str, model: Path | None, param: list[str]):
    """A detector of ``kind`` with its model file and other config fields KEY=VALUE (ValueError if bad)."""
    return detector_config(kind, model, param).build()


def detector_config(kind: str, model: Path | None, param: list[str]):
    """The typed config of a detector of ``kind`` with its model file and other fields KEY=VALUE (ValueError
    if bad); ``config.build`` builds it (in a worker process too: configs pickle)."""
    import gaitcap.acquisition.detectors  # noqa: F401  (registers the detector kinds)
    from gaitcap.acquisition.detectors.base import config_class

    cls = config_class(kind)
    params = key_values(param)
    fields = {f.name for f in dataclasses.fields(cls)}
    if model is not None:
        key = "model_path" if "model_path" in fields else "model"
        if key not in fields:
            raise ValueError(f"--model: detector {kind} takes no model file")
        params[key] = model if key == "model_path" else str(model)
    return cls(**params)


def completion_plan(kind: str, model: Path | None, param: list[str], workers: int | None, *,
                    only_missing: bool = False):
    """``--complete-with KIND [--complete-model PATH] [--complete-param K=V] [--complete-workers N]
    [--complete-only-missing]`` as the one path's
    :class:`~gaitcap.services.processing.completion.CompletionSettings`; None for kind ``none``. Every recorded
    frame is detected again unless ``only_missing``: the refined result then does not depend on what the live
    pass happened to catch, and is the same wherever the recording is processed."""
    from gaitcap.services.processing.completion import CompletionSettings

    if kind == "none":
        return None
    return CompletionSettings(detector_config(kind, model, param), workers=workers, redetect_all=not only_missing)


COMPLETE_WITH_HELP = ("Detect the recorded frames from their images before the refined stage with this detector "
                      "kind (mediapipe | onnx; none: the live keypoints only): every frame, so the refined result "
                      "does not depend on what the live pass caught (--complete-only-missing: only the frames "
                      "without live keypoints).")
ONLY_MISSING_HELP = ("Complete only the frames without live keypoints (faster by the live coverage; the refined "
                     "result then rests on the live keypoints too).")


def frame_count(files: list[Path]) -> int:
    from gaitcap.acquisition.drivers.video import VideoCamera

    total = 0
    for f in files:
        cam = VideoCamera(f, realtime=False)
        cam.open()
        total += cam.frame_count or 0
        cam.close()
    return total


def register(app: typer.Typer) -> None:
    @app.command("detect")
    def detect_cmd(
        videos: Path = typer.Option(..., "--videos", help="Folder with one video file per camera (camera = file stem)."),
        detector: str = typer.Option("mediapipe", "--detector", help="Detector kind: mediapipe | onnx."),
        model: Path | None = typer.Option(None, "--model", help="Model file (onnx: the .onnx top-down model)."),
        param: list[str] = typer.Option([], "--param", help="Other detector config field KEY=VALUE."),
        fps: float | None = typer.Option(None, "--fps", help="Frame rate (default: the files')."),
        out: Path = typer.Option(..., "--out", help="Output keypoints .npz: everyone, (C, T, P, J, 3), most "
                                 "confident first (the input of `gaitcap reconstruct` / `process`)."),
        one_per_camera: bool = typer.Option(
            False, "--one-per-camera", help="Write only the most confident person of each camera frame (C, T, J, 3), "
            "chosen in each camera on its own: only for recordings with one person in view."),
    ) -> None:
        """2D keypoints of everyone in existing multi-view videos -> NPZ for `gaitcap reconstruct` / `process`."""
        from dataclasses import replace

        import numpy as np
        from gaitcap.acquisition.video_detect import detect_videos, find_videos
        from gaitcap.acquisition.writers import save_multi_npz

        with user_errors():
            files = find_videos(videos)
            det = build_detector(detector, model, param)
            with progress(total=frame_count(files) or None, desc="detect", unit="frame") as bar:
                result = detect_videos(files, det, fps=fps, on_frame=lambda: bar.update(1))
            save_multi_npz(replace(result, keypoints=result.keypoints[:, :, :1]) if one_per_camera else result, out)
        seen = (np.nan_to_num(result.keypoints[..., 2]) > 0.5).any(-1)  # (C, T, P)
        typer.echo(f"{out}: {len(files)} cameras x {result.shape[1]} frames ({result.fps_hz:g} fps), "
                   f"{result.skeleton.name}, up to {int(seen.sum(-1).max())} people per camera frame"
                   + (" (kept the most confident per camera)" if one_per_camera else ""))
