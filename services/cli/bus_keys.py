"""``gaitcap bus-keys``: the lab CA, a certificate and a password per bus node (mutual TLS on the bus)."""

from __future__ import annotations

from pathlib import Path

import typer
from gaitcap.services.cli._common import user_errors


def register(app: typer.Typer) -> None:
    @app.command("bus-keys")
    def bus_keys(
        bus: Path = typer.Option(..., "--bus", envvar="GAITCAP_BUS", help="Bus file (JSON5) naming every node."),
        out: Path | None = typer.Option(None, "--out", help="Keys folder (default: the bus file's security.keys_dir)."),
        client: list[str] = typer.Option([], "--client", help="Extra identity that listens nowhere (CLI tools)."),
        days: int = typer.Option(825, "--days", help="Node certificates' validity, days."),
    ) -> None:
        """Create the lab CA, each node's certificate and key, and the bus passwords (kept if present)."""
        from gaitcap.services.bus.certs import make_bus_keys
        from gaitcap.services.bus.session import load_bus_config

        with user_errors():
            cfg = load_bus_config(bus)
            folder = out or (cfg.security.keys_dir if cfg.security is not None else None)
            if folder is None:
                raise ValueError("--out: the bus file has no security.keys_dir; give the keys folder")
            identities = {n: cfg.nodes.get(n) for n in [*cfg.identities, *client]}
            made = make_bus_keys(identities, folder, days=days)
        typer.echo(f"bus keys in {folder}: created {', '.join(made) or 'nothing (all present)'}")
        typer.echo("Copy to each host: ca.pem, passwords.txt and that host's <node>.pem/.key (mode 0600). "
                   "Keep ca.key off the rig.")
