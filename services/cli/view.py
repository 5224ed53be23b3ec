"""``gaitcap view TRIAL``: open a processed trial in Rerun, and list its files for Foxglove."""

from __future__ import annotations

import logging
import os
import shutil
import subprocess
import sys
from pathlib import Path

import typer
from gaitcap.services.catalog.paths import DEFAULT_DATA_DIR
from gaitcap.services.cli._common import user_errors

log = logging.getLogger(__name__)

STAGE_ORDER = ("refined", "preliminary")


def rerun_viewer() -> str | None:
    """The ``rerun`` command (on PATH, else beside this Python), or None."""
    found = shutil.which("rerun")
    if found:
        return found
    beside = Path(sys.executable).with_name("rerun")
    return str(beside) if beside.is_file() and os.access(beside, os.X_OK) else None


def has_display() -> bool:
    """False on a Linux machine without a graphical session (the native viewer cannot open there)."""
    return not sys.platform.startswith("linux") or bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _stage_with_rrd(files, stage: str | None) -> str:
    stages = [stage] if stage else list(STAGE_ORDER)
    for s in stages:
        if files.stage_file(s, "rerun_rrd").is_file():
            return s
    raise FileNotFoundError(f"trial {files.root.name}: no Rerun file for stage {' or '.join(stages)} in "
                            f"{files.root} (is the trial processed?)")


def _trial_cameras(recording: Path) -> list[str]:
    from gaitcap.acquisition.recording.reader import read_calibration

    return list(read_calibration(recording).names)


def register(app: typer.Typer) -> None:
    @app.command("view")
    def view(
        trial: str = typer.Argument(..., help="Trial id (its folder under DATA_DIR/trials)."),
        data_dir: Path = typer.Option(DEFAULT_DATA_DIR, "--data-dir", envvar="GAITCAP_DATA_DIR",
                                      help="The clinic's data folder."),
        stage: str = typer.Option(None, "--stage", help="refined or preliminary (default: the latest there is)."),
        foxglove_layout: bool = typer.Option(False, "--foxglove-layout",
                                             help="Also write a Foxglove layout for this trial's cameras."),
        no_open: bool = typer.Option(False, "--no-open", help="Only list the files; open nothing."),
    ) -> None:
        """Open TRIAL's Rerun recording (rig, images, 2D and 3D, gait events) in the Rerun viewer, and
        list the MCAPs and layout to open in Foxglove."""
        from gaitcap.services.processing.artifacts import STAGES, trial_files
        from gaitcap.services.processing.viewers.foxglove_layout import layout_json, shipped_layout_path

        with user_errors():
            if stage is not None and stage not in STAGES:
                raise ValueError(f"--stage: must be one of {STAGES}, got {stage!r}")
            files = trial_files(data_dir, trial)
            chosen = _stage_with_rrd(files, stage)
            rrd = files.stage_file(chosen, "rerun_rrd")
            results = files.stage_file(chosen, "results_mcap")
            layout = files.root / "foxglove_layout.json"  # the trial's own, when written before
            if foxglove_layout:
                layout.write_text(layout_json(_trial_cameras(files.recording)))
            elif not layout.is_file():
                layout = shipped_layout_path()
        typer.echo(f"Rerun:    {rrd}")
        typer.echo(f"Foxglove: open {files.recording} and {results} together; layout {layout}")
        if no_open:
            return
        viewer = rerun_viewer()
        if viewer is None:
            typer.echo("The Rerun viewer is not installed here: `pip install rerun-sdk`, then `rerun "
                       f"{rrd}`.", err=True)
            raise typer.Exit(code=1)
        if not has_display():
            typer.echo(f"No display here: copy {rrd} to a machine with a screen and run `rerun {rrd.name}` "
                       "(Rerun's viewer, from `pip install rerun-sdk`).", err=True)
            raise typer.Exit(code=1)
        subprocess.Popen([viewer, str(rrd)], start_new_session=True)
        typer.echo(f"opened {rrd.name} in {viewer}")
