"""``gaitcap simulate``: write a synthetic trial (calibration, keypoints, ground truth) to a folder;
``gaitcap simulate-board``: write a simulated calibration recording (board MCAP + true calibration)."""

from __future__ import annotations

from pathlib import Path

import typer
from gaitcap.services.cli._common import progress, user_errors


def register(app: typer.Typer) -> None:
    @app.command("simulate")
    def simulate(
        out: Path = typer.Option(..., "--out", help="Output folder (created)."),
        preset: str = typer.Option("paper", "--preset", help="Detection noise: clean, paper or hard."),
        seconds: float = typer.Option(30.0, "--seconds", help="Trial duration in s (>= 4)."),
        cameras: int = typer.Option(10, "--cameras", help="Number of cameras (>= 2)."),
        people: int = typer.Option(1, "--people", help="1: patient; 2: + therapist; 3: + a bystander."),
        seed: int = typer.Option(0, "--seed", help="Random seed (the trial is deterministic given it)."),
        fps: float = typer.Option(30.0, "--fps", help="Frame rate (frames/s)."),
        as_json: bool = typer.Option(False, "--json", help="Print the summary as one JSON object."),
    ) -> None:
        """Simulate a patient walking the room's diagonal, seen by a camera rig; write calibration.toml,
        keypoints.npz and ground_truth.npz to --out and print a ground-truth gait summary."""
        from gaitcap.simulator import make_trial
        from gaitcap.simulator.files import save_trial, summary_json, summary_lines

        with user_errors():
            trial = make_trial(preset=preset, seconds=seconds, cameras=cameras, people=people, seed=seed, fps=fps)
            paths = save_trial(trial, out)
        if as_json:
            typer.echo(summary_json(trial))
            return
        for line in summary_lines(trial):
            typer.echo(line)
        typer.echo("wrote " + ", ".join(str(p) for p in paths.values()))

    @app.command("simulate-board")
    def simulate_board(
        out: Path = typer.Option(..., "--out", help="Output folder (created): board.mcap and true_calibration.toml."),
        board: str = typer.Option("checkerboard", "--board", help="Board kind: checkerboard (7x5, 110 mm) | charuco (5x7, 109 mm)."),
        frames: int = typer.Option(600, "--frames", help="Frames at 10 frames/s (600: a 60 s recording)."),
        scale: float = typer.Option(1.0, "--scale", help="Image size as a fraction of 1920x1200 px."),
        cameras: int = typer.Option(10, "--cameras", help="The first N cameras of the synthetic 10-camera room (2-10)."),
        floor_frames: int = typer.Option(20, "--floor-frames", help="Frames with the board still on the floor at the origin (half as many at each of 3 more spots)."),
        seed: int = typer.Option(0, "--seed", help="Random seed."),
    ) -> None:
        """Render a calibration board carried through the synthetic room, seen by every camera, as a
        recording (then: gaitcap calibrate OUT/board.mcap --out calib.toml --compare OUT/true_calibration.toml)."""
        from gaitcap.acquisition.boards.detection import BoardConfig
        from gaitcap.acquisition.writers import save_rig
        from gaitcap.simulator.board_clip import BoardClipConfig, write_board_clip

        with user_errors():
            make = {"checkerboard": BoardConfig.checkerboard, "charuco": BoardConfig.charuco}
            if board not in make:
                raise ValueError(f"--board: choose checkerboard or charuco, got {board!r}")
            config = BoardClipConfig(board=make[board](), frames=frames, scale=scale, cameras=cameras,
                                     floor_frames=floor_frames, seed=seed)
            out.mkdir(parents=True, exist_ok=True)
            with progress(total=frames, desc="rendering", unit="frame") as bar:
                mcap, truth = write_board_clip(out / "board.mcap", config,
                                               progress=lambda done, total: bar.update(1))
            truth_path = save_rig(truth, out / "true_calibration.toml")
        typer.echo(f"wrote {mcap} ({frames} frames x {cameras} cameras, {truth[0].size_px[0]}x{truth[0].size_px[1]} px) "
                   f"and {truth_path}")
