"""``gaitcap reconstruct``: 3D trajectories from 2D keypoints and a calibration."""

from __future__ import annotations

import enum
import json
import math
from pathlib import Path

import typer
from gaitcap.reconstruction.fileio import atomic_write_text
from gaitcap.services.cli._common import progress, user_errors


class MethodName(enum.StrEnum):
    dlt = "dlt"
    robust = "robust"
    explicit = "explicit"
    implicit = "implicit"



def _jsonable(value):
    """Metrics with NaN/inf as null (strict JSON)."""
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


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


def reconstruct_command(
    calibration: Path = typer.Option(..., "--calibration", help="aniposelib/Pose2Sim TOML or gaitcap JSON."),
    keypoints: Path = typer.Option(..., "--keypoints", help="NPZ file, OpenPose JSON folder or trial MCAP."),
    method: MethodName = typer.Option(MethodName.implicit, "--method", help="Reconstruction method."),
    out: Path = typer.Option(..., "--out", help="Result NPZ (points_mm, times_s, joint_names, camera_weights)."),
    trc: Path | None = typer.Option(None, "--trc", help="Also write an OpenSim TRC file."),
    as_json: bool = typer.Option(False, "--json", help="Print the metrics as one JSON object."),
    paper: bool = typer.Option(False, "--paper", help="The paper's configuration (explicit/implicit; slow)."),
    steps: int | None = typer.Option(None, "--steps", help="Steps of the --paper configuration."),
    fps: float = typer.Option(30.0, "--fps", help="Frame rate when the input has no times."),
    skeleton: str | None = typer.Option(None, "--skeleton", help="Keypoint layout if not in the input."),
    consistent: bool = typer.Option(
        False, "--consistent-person", help="Several people: take the one consistent across views."),
) -> None:
    """Reconstruct 3D keypoint trajectories (mm) from multi-camera 2D keypoints."""
    with user_errors():
        from gaitcap.acquisition.keypoint_files import read_keypoints_input
        from gaitcap.reconstruction.calibration_io import load_rig
        from gaitcap.reconstruction.methods import reconstruct
        from gaitcap.reconstruction.trc import to_trc

        rig = load_rig(calibration)
        det = read_keypoints_input(keypoints, rig=rig, fps=fps, skeleton=skeleton, consistent=consistent)
        config = _method(method, paper, steps)
        with progress(desc=method.value, unit="step") as bar:

            def report(done: int, total: int) -> None:
                bar.total = total
                bar.n = done
                bar.refresh()

            rec = reconstruct(det, rig, method=config, progress=report)
        rec.save_npz(out)
        if trc is not None:
            atomic_write_text(trc, to_trc(rec.points_mm, rec.times_s, rec.joint_names, filename=trc.name))
        if as_json:
            typer.echo(json.dumps(_jsonable({"method": rec.method, **rec.metrics, "losses": rec.losses})))
        else:
            m = rec.metrics
            typer.echo(
                f"{rec.method}: {rec.points_mm.shape[0]} frames x {rec.points_mm.shape[1]} joints -> {out}; "
                f"GC_5 {m['GC_5']:.3f} GC_10 {m['GC_10']:.3f} GC_20 {m['GC_20']:.3f} L_reproj {m['L_reproj']:.2f} "
                f"L_smooth {m['L_smooth']:.2f} mm L_skeleton {m['L_skeleton']:.2f} mm"
            )


def register(app: typer.Typer) -> None:
    app.command("reconstruct")(reconstruct_command)
