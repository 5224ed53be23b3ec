"""``gaitcap serve``: the clinic web page and REST API (uvicorn, 127.0.0.1 by default; HTTPS built in)."""

from __future__ import annotations

from pathlib import Path

import typer
from gaitcap.services.cli._common import user_errors


def board_fields(path: Path) -> dict:
    """The board of a board file (any format it reads) as a gaitcap board file's ``[board]`` fields;
    ValueError naming the file and field when it is not a board."""
    import tomllib

    from gaitcap.acquisition.boards.file import board_to_toml, read_board_file

    return tomllib.loads(board_to_toml(read_board_file(path)))["board"]


def board_words(board: dict | None, path: Path | None) -> str:
    """The board serve records on board recordings, in one line naming where it came from."""
    from gaitcap.acquisition.boards.detection import BoardConfig
    from gaitcap.acquisition.boards.file import board_from_dict

    if board is None:
        return f"{BoardConfig().describe()} (the default board: no --board-file)"
    return f"{board_from_dict({'board': board}, source=str(path)).describe()} (board file {path})"


def register(app: typer.Typer) -> None:
    @app.command()
    def serve(
        data_dir: Path = typer.Option(Path("runs/clinic"), "--data-dir", envvar="GAITCAP_DATA_DIR",
                                      help="Where trial files go (recordings, results), accounts and the audit log."),
        catalog: str = typer.Option("", "--catalog", envvar="GAITCAP_CATALOG",
                                    help="SQLite path or SQLAlchemy URL (default DATA_DIR/catalog.sqlite)."),
        host: str = typer.Option("127.0.0.1", "--host", envvar="GAITCAP_HOST", help="Bind address."),
        port: int = typer.Option(8000, "--port", envvar="GAITCAP_PORT"),
        tls_cert: Path | None = typer.Option(None, "--tls-cert", envvar="GAITCAP_TLS_CERT", help="HTTPS certificate (PEM)."),
        tls_key: Path | None = typer.Option(None, "--tls-key", envvar="GAITCAP_TLS_KEY", help="HTTPS private key (PEM)."),
        self_signed: bool = typer.Option(False, "--self-signed",
                                         help="HTTPS with a certificate from a lab CA made in DATA_DIR/tls (kept)."),
        plain_http: bool = typer.Option(False, "--plain-http-beyond-loopback",
                                        help="Listen beyond loopback without TLS (only behind a TLS reverse proxy)."),
        bus: Path | None = typer.Option(None, "--bus", envvar="GAITCAP_BUS", help="Bus file (JSON5)."),
        no_bus: bool = typer.Option(False, "--no-bus", help="Serve the catalog only (no recorder, cameras)."),
        node: str = typer.Option("api", "--node", help="Bus node name of the API."),
        room: str = typer.Option("", "--room", envvar="GAITCAP_ROOM",
                                 help="The capture room this API runs (its cameras, Start and Stop), registered with "
                                      "the catalog; several rooms share one central catalog. Default: the one room."),
        sim_scene: bool = typer.Option(False, "--sim-scene",
                                       help="Calibrate switches simulated cameras to the board (the demo stack)."),
        board_file: Path | None = typer.Option(None, "--board-file", envvar="GAITCAP_BOARD_FILE",
                                               help="The clinic's calibration board (TOML/JSON board file; "
                                                    "caliscope, anipose, Pose2Sim files too). Default: 7 x 5 "
                                                    "checkerboard of 110 mm."),
    ) -> None:
        """Serve the clinic page and the REST API (docs at /docs). Accounts: gaitcap user add."""
        from gaitcap.api.server import serve as run
        from gaitcap.api.settings import Settings

        with user_errors():
            if self_signed and tls_cert is None:
                from gaitcap.services.bus.certs import web_certificate

                tls_cert, tls_key = web_certificate(host if host not in ("0.0.0.0", "::") else "localhost",
                                                    data_dir / "tls")
                typer.echo(f"HTTPS certificate {tls_cert} (trust {data_dir / 'tls' / 'ca.pem'} in the browsers)")
            board = board_fields(board_file) if board_file else None
            settings = Settings.from_env(data_dir=data_dir, host=host, port=port, tls_cert=tls_cert, tls_key=tls_key,
                                         plain_http_beyond_loopback=plain_http,
                                         catalog_url=catalog or str(data_dir / "catalog.sqlite"), board=board,
                                         room=room)
            if sim_scene and no_bus:
                raise ValueError("--sim-scene: the simulated cameras are reached over the bus (drop --no-bus)")
            link, scene = None, None
            if not no_bus:
                from gaitcap.services.bus.session import default_bus_config
                from gaitcap.services.live.bus_link import BusLink
                from gaitcap.services.live.sim_scene import BusSceneControl

                link = BusLink(default_bus_config(bus), node=node)
                scene = BusSceneControl(link.session, link.bus) if sim_scene else None
            typer.echo(f"calibration board: {board_words(board, board_file)}")
            typer.echo(f"gaitcap clinic page: {settings.scheme}://{host}:{port}/")
        run(settings, link, scene=scene)
