"""``gaitcap serve``: the clinic web page and REST API (uvicorn, 127.0.0.1 by default)."""

from __future__ import annotations

from pathlib import Path

import typer
from gaitcap.services.catalog.paths import DEFAULT_DATA_DIR, catalog_url
from gaitcap.services.cli._common import user_errors


def register(app: typer.Typer) -> None:
    @app.command()
    def serve(
        data_dir: Path = typer.Option(DEFAULT_DATA_DIR, "--data-dir", envvar="GAITCAP_DATA_DIR",
                                      help="Where trial files go (recordings, results)."),
        catalog: str = typer.Option("", "--catalog", envvar="GAITCAP_CATALOG",
                                    help="SQLite path or SQLAlchemy URL (default DATA_DIR/catalog.sqlite)."),
        host: str = typer.Option("127.0.0.1", "--host", envvar="GAITCAP_HOST", help="Bind address."),
        port: int = typer.Option(8000, "--port", envvar="GAITCAP_PORT"),
        token: str = typer.Option("", "--token", envvar="GAITCAP_TOKEN",
                                  help="API token (generated and printed when empty)."),
        bus: Path | None = typer.Option(None, "--bus", envvar="GAITCAP_BUS", help="Bus file (JSON5)."),
        no_bus: bool = typer.Option(False, "--no-bus", help="Serve the catalog only (no recorder, cameras)."),
        node: str = typer.Option("api", "--node", help="Bus node name of the API."),
    ) -> None:
        """Serve the clinic page and the REST API (OpenAPI docs at /docs)."""
        from gaitcap.api.server import serve as run
        from gaitcap.api.settings import Settings, new_token

        with user_errors():
            if not token:
                token = new_token()
                typer.echo(f"API token: {token}")
            settings = Settings.from_env(tokens={token: "clinic"}, data_dir=data_dir, host=host, port=port,
                                         catalog_url=catalog_url(data_dir, catalog))
            link = None
            if not no_bus:
                from gaitcap.services.bus.session import default_bus_config
                from gaitcap.services.live.bus_link import BusLink

                link = BusLink(default_bus_config(bus), node=node)
            typer.echo(f"gaitcap clinic page: http://{host}:{port}/#token={token}")
        run(settings, link)
