"""``gaitcap calibrate RECORDING.mcap|FOLDER [--board checkerboard|charuco ...] --out CALIB.toml``."""

from __future__ import annotations

from pathlib import Path

import typer
from gaitcap.services.cli._common import progress, user_errors


def _squares(text: str) -> tuple[int, int]:
    x, sep, y = text.lower().partition("x")
    if not sep or not x.isdigit() or not y.isdigit():
        raise ValueError(f"--squares: expected COLSxROWS such as 7x5, got {text!r}")
    return int(x), int(y)


def _summary(report) -> str:
    lines = [f"{'camera':<10} {'views':>6} {'corners':>8} {'mean px':>8} {'p95 px':>7} {'coverage':>9}  status"]
    for q in report.cameras:
        status = "ok" if q.ok else "FAILED: " + "; ".join(q.problems)
        lines.append(
            f"{q.name:<10} {q.n_detections:>6} {q.n_corners:>8} {q.reprojection_mean_px:>8.3f} "
            f"{q.reprojection_p95_px:>7.3f} {100 * q.coverage:>8.0f}%  {status}"
        )
    lines.append(
        f"reprojection RMS {report.reprojection_rms_px:.3f} px, p95 {report.reprojection_p95_px:.3f} px; "
        f"square {report.square_measured_mm:.2f} mm measured vs {report.square_mm:g} mm "
        f"({report.square_residual_pct:+.2f} %); {report.n_outliers} outlier corners; "
        f"world from {report.floor_frames} floor frame(s){' (turned over)' if report.world_flipped else ''}"
    )
    return "\n".join(lines)


def _comparison(cmp) -> str:
    lines = [f"{'camera':<10} {'centre mm':>10} {'rotation deg':>13} {'focal %':>8} {'rig shape mm':>13}"]
    for c in cmp.cameras:
        lines.append(f"{c.name:<10} {c.centre_mm:>10.2f} {c.rotation_deg:>13.3f} {c.focal_pct:>+8.3f} "
                     f"{c.aligned_centre_mm:>13.2f}")
    lines.append(f"max: centre {cmp.centre_mm_max:.2f} mm, rotation {cmp.rotation_deg_max:.3f} deg, rig shape "
                 f"{cmp.aligned_centre_mm_max:.2f} mm; world frame: tilt {cmp.world_tilt_deg:.3f} deg, heading "
                 f"{cmp.world_heading_deg:.3f} deg, shift {cmp.world_shift_mm:.2f} mm")
    return "\n".join(lines)


def register(app: typer.Typer) -> None:
    @app.command("calibrate")
    def calibrate_cmd(
        recording: Path = typer.Argument(..., help="Board recording: a trial .mcap, or a folder with <camera>/ images or <camera>.mp4 videos."),
        out: Path = typer.Option(..., "--out", help="Calibration to write (.toml aniposelib/Pose2Sim, or .json gaitcap)."),
        board: str = typer.Option("checkerboard", "--board", help="Board kind: checkerboard | charuco."),
        squares: str | None = typer.Option(None, "--squares", help="Squares COLSxROWS (default 7x5 checkerboard, 5x7 charuco)."),
        square_mm: float | None = typer.Option(None, "--square-mm", help="Square side in mm (default 110 checkerboard, 109 charuco)."),
        marker_mm: float | None = typer.Option(None, "--marker-mm", help="ChArUco marker side in mm (default 0.75 x square)."),
        dictionary: str = typer.Option("DICT_4X4_50", "--dictionary", help="ChArUco ArUco dictionary."),
        distortion: str = typer.Option("k1", "--distortion", help="Distortion terms: k1 (the paper's) | k1k2p1p2k3."),
        every: int = typer.Option(1, "--every", help="Use every N-th frame."),
        max_frames: int | None = typer.Option(None, "--max-frames", help="Use at most this many frames."),
        floor_frame: int | None = typer.Option(None, "--floor-frame", help="Index, among the frames where the board was found, of one with the board on the floor (default 0)."),
        report_path: Path | None = typer.Option(None, "--report", help="Quality report JSON (default: OUT with .report.json)."),
        compare: Path | None = typer.Option(None, "--compare", help="A reference calibration (the last one, or a simulation's truth) to compare the new one with."),
    ) -> None:
        """Calibrate all cameras from a board recording; writes the calibration and its quality report."""
        from gaitcap.acquisition.board import BoardConfig
        from gaitcap.acquisition.board_recording import FrameSelection, detect_recording
        from gaitcap.reconstruction.calibration import (
            CalibrationConfig,
            DistortionModel,
            IntrinsicsConfig,
            WorldFrameConfig,
            calibrate_from_observations,
        )
        from gaitcap.reconstruction.calibration.compare import compare_rigs
        from gaitcap.reconstruction.calibration_io import load_rig, save_rig

        with user_errors():
            reference = load_rig(compare) if compare is not None else None
            if out.suffix.lower() not in (".toml", ".json"):
                raise ValueError(f"--out {out}: use a .toml or .json file name")
            models = {m.value: m for m in DistortionModel}
            if distortion not in models:
                raise ValueError(f"--distortion: choose one of {sorted(models)}, got {distortion!r}")
            make = {"checkerboard": BoardConfig.checkerboard, "charuco": BoardConfig.charuco}
            if board not in make:
                raise ValueError(f"--board: choose checkerboard or charuco, got {board!r}")
            cfg = make[board]()
            sx, sy = _squares(squares) if squares else (cfg.squares_x, cfg.squares_y)
            cfg = BoardConfig(board, sx, sy, square_mm or cfg.square_mm, marker_mm, dictionary)  # type: ignore[arg-type]
            config = CalibrationConfig(
                intrinsics=IntrinsicsConfig(distortion=models[distortion]),
                world=WorldFrameConfig(floor_frame=floor_frame),
            )
            with progress(desc="finding the board", unit="img") as bar:
                obs = detect_recording(recording, board=cfg, selection=FrameSelection(every, max_frames),
                                       progress=lambda done, total: bar.update(1))
            typer.echo(f"board {obs.board.name}: {int(obs.views().sum())} views in {obs.shape[1]} frames", err=True)
            result = calibrate_from_observations(obs, config=config)
            save_rig(result.rig, out, metadata={"error": result.report.reprojection_rms_px})
            report_file = report_path or out.with_suffix(".report.json")
            result.report.save_json(report_file)
            comparison = compare_rigs(reference, result.rig) if reference is not None else None
        typer.echo(_summary(result.report))
        if comparison is not None:
            typer.echo(f"compared with {compare}:")
            typer.echo(_comparison(comparison))
        typer.echo(f"wrote {out} and {report_file}")
        if result.report.failed_cameras:
            typer.echo(f"warning: cameras {list(result.report.failed_cameras)} failed the quality checks", err=True)
