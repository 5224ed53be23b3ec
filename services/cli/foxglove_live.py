"""``gaitcap foxglove-live``: watch the live rig in Foxglove (a Foxglove WebSocket server on the bus)."""

from __future__ import annotations

from pathlib import Path

import typer
from gaitcap.services.cli._common import stop_on_signals, user_errors


def register(app: typer.Typer) -> None:
    @app.command("foxglove-live")
    def foxglove_live(
        bus: Path | None = typer.Option(None, "--bus", help="Bus file (JSON5); default $GAITCAP_BUS or local."),
        node: str | None = typer.Option(None, "--node", help="Identity on a secured bus (a security.clients entry)."),
        host: str = typer.Option("127.0.0.1", "--host", help="Loopback address to bind (remote: an SSH tunnel)."),
        port: int = typer.Option(8765, "--port", help="WebSocket port."),
        preview_fps: float = typer.Option(5.0, "--preview-fps", help="Frames per second and camera relayed."),
        calibration: Path | None = typer.Option(None, "--calibration",
                                                help="Rig calibration (TOML/JSON): cameras as CameraCalibration."),
    ) -> None:
        """Relay the live bus to Foxglove: open ws://HOST:PORT in Foxglove (Open connection)."""
        from gaitcap.acquisition.readers import load_rig
        from gaitcap.services.bus.session import default_bus_config, open_session
        from gaitcap.services.nodes.foxglove_live import FoxgloveLiveConfig, FoxgloveRelay

        with user_errors():
            config = FoxgloveLiveConfig(host=host, port=port, preview_fps=preview_fps)
            rig = load_rig(calibration) if calibration is not None else None
            cfg = default_bus_config(bus)
            session = open_session(cfg, node)
            relay = FoxgloveRelay(session, cfg, config, rig=rig)
        stop = stop_on_signals()
        typer.echo(f"Foxglove live view: ws://{host}:{relay.port} (Ctrl-C stops)")
        stop.wait()
        relay.close()
        session.close()
