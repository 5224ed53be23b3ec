"""``gaitcap simulate``: write a synthetic trial (calibration, keypoints, ground truth) to a folder."""

from __future__ import annotations

from pathlib import Path

import typer

from services.cli._common import user_errors


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
        from acquisition.synthetic import make_trial
        from acquisition.synthetic.files import save_trial, summary_json, summary_lines

        with user_errors():
            trial = make_trial(preset=preset, seconds=seconds, cameras=cameras, people=people, seed=seed, fps=fps)
            paths = save_trial(trial, out)
        if as_json:
            typer.echo(summary_json(trial))
            return
        for line in summary_lines(trial):
            typer.echo(line)
        typer.echo("wrote " + ", ".join(str(p) for p in paths.values()))
