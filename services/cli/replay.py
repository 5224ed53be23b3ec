"""``gaitcap replay TRIAL.mcap [--rate 1.0|max]``: republish a recording on the bus."""

from __future__ import annotations

from pathlib import Path

import typer
from gaitcap.services.cli._common import user_errors


def _rate(text: str) -> float | None:
    if text.strip().lower() == "max":
        return None
    try:
        return float(text)
    except ValueError:
        raise ValueError(f"--rate: expected a number or 'max', got {text!r}") from None


def register(app: typer.Typer) -> None:
    @app.command("replay")
    def replay_cmd(
        recording: Path = typer.Argument(..., help="Trial .mcap (or .mcap.part left by a crash)."),
        rate: str = typer.Option("1.0", "--rate", help="Speed: 1.0 = real time, 2 = twice, 'max' = unpaced."),
        keypoints: bool = typer.Option(True, "--keypoints/--no-keypoints",
                                       help="Also publish the recorded keypoints (off: let a detector node redo them)."),
        bus: Path | None = typer.Option(None, "--bus", help="Bus file (JSON5); default $GAITCAP_BUS or local."),
        node: str = typer.Option("replay", "--node", help="Node name (bus file entry)."),
        wait_for: list[str] = typer.Option([], "--wait-for", help="Wait until these nodes are alive first."),
        wait_s: float = typer.Option(1.0, "--settle-s", help="Pause after connecting, s (lets subscriptions arrive)."),
    ) -> None:
        """Republish frames, keypoints and camera status of a recording, paced like the original."""
        import time

        from gaitcap.services.bus.session import alive_nodes, declare_alive, default_bus_config, open_session
        from gaitcap.services.nodes.replay import Replayer

        with user_errors():
            pace = _rate(rate)
            cfg = default_bus_config(bus)
            session = open_session(cfg, node)
            token = declare_alive(session, cfg, node)
            deadline = time.monotonic() + 30
            while wait_for and not set(wait_for) <= alive_nodes(session, cfg):
                if time.monotonic() > deadline:
                    raise ValueError(f"--wait-for: nodes {sorted(set(wait_for) - alive_nodes(session, cfg))} not alive after 30 s")
                time.sleep(0.2)
            time.sleep(wait_s)
            stats = Replayer(session, cfg.keys, rate=pace, keypoints=keypoints).run(recording)
        token.undeclare()
        session.close()
        typer.echo(f"replayed {recording}: {stats.frames} frames, {stats.keypoints} keypoint messages, "
                   f"{stats.status} status messages in {stats.duration_s:.1f} s")
