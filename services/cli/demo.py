"""``gaitcap demo``: the whole stack on embedded defaults (simulated 10-camera rig, detector, recorder,
worker, API; Zenoh peers on loopback) as real processes. Prints the page's URL and the demo account's password and runs
until Ctrl-C; ``--auto`` records one trial without a browser, prints the metrics and shuts down."""

from __future__ import annotations

from pathlib import Path

import typer
from gaitcap.services.catalog.paths import DEMO_DATA_DIR
from gaitcap.services.cli._common import stop_on_signals, user_errors


def register(app: typer.Typer) -> None:
    @app.command()
    def demo(
        auto: bool = typer.Option(False, "--auto", help="Run one trial without a browser, print metrics, exit."),
        seconds: float = typer.Option(20.0, "--seconds", help="--auto: how long the trial records (s)."),
        data_dir: Path = typer.Option(DEMO_DATA_DIR, "--data-dir", help="Catalog, recordings, results, logs."),
        port: int = typer.Option(8000, "--port", help="Web page / API port on 127.0.0.1."),
        bus_port: int = typer.Option(7447, "--bus-port", help="First bus port (one per node, on 127.0.0.1)."),
        cameras: int = typer.Option(10, "--cameras", help="Simulated cameras."),
        camera_nodes: int = typer.Option(1, "--camera-nodes", help="Processes the simulated cameras are dealt to "
                                         "(more: headroom on a busy machine; one synchronised frame count)."),
        size: str = typer.Option("240x180", "--size", help="Simulated image size WIDTHxHEIGHT (px)."),
        workers: int = typer.Option(1, "--workers", help="Reconstruction workers."),
        board_clip: str = typer.Option("short", "--board-clip", help="Board shown on Calibrate: short (6 s) | full (60 s; "
                                       "with --size 960x600 or larger it meets the calibration targets)."),
        refine: bool = typer.Option(True, "--refine/--no-refine", help="Run the refined (implicit) fit."),
        people: int = typer.Option(1, "--people", help="People in the simulated room: 1 patient, 2 with a "
                                                       "therapist beside, 3 also someone standing."),
        first_trial: bool = typer.Option(True, "--first-trial/--no-first-trial",
                                         help="Record one walk automatically once the stack is up, so the page "
                                              "already shows a finished trial (ignored with --auto)."),
        wait_stall: float = typer.Option(600.0, "--wait-stall", help="Give up on the trial's results when the "
                                         "worker reported no new stage or progress for this long (s)."),
        wait_limit: float = typer.Option(3600.0, "--wait-limit", help="Give up on the trial's results after "
                                         "this long after Stop in all (s)."),
        plain_bus: bool = typer.Option(False, "--plain-bus", help="A plain TCP bus on loopback: no TLS, passwords "
                                       "or access control, any local process can use it (default: secured)."),
        catalog: str = typer.Option("", "--catalog", envvar="GAITCAP_CATALOG",
                                    help="SQLite path or SQLAlchemy URL, e.g. a central PostgreSQL "
                                         "postgresql+psycopg://gaitcap@dbhost/gaitcap (password in ~/.pgpass or "
                                         "PGPASSFILE; default DATA_DIR/catalog.sqlite)."),
        room: str = typer.Option("", "--room", help="The capture room this stack runs, registered with the catalog "
                                                    "(several rooms on one central catalog; default: the one room)."),
        gige: bool = typer.Option(False, "--gige", help="The --cameras are fake GigE Vision cameras "
                                  "(arv-fake-gv-camera-0.8, the real protocol, behind a link in a network namespace: "
                                  "needs root) through the Aravis driver; their test pattern has nobody in it, so "
                                  "the keypoints come from the simulated detector."),
    ) -> None:
        """Bring up the whole clinic stack (simulated rig) and print the web page's URL."""
        import logging

        from gaitcap.api.settings import new_token
        from gaitcap.services.ops.auto_trial import WaitLimits
        from gaitcap.services.ops.stack import Stack, StackConfig, bus_keys_dir

        with user_errors():
            cfg = StackConfig(data_dir=data_dir, token=new_token(), port=port, bus_base_port=bus_port,
                              cameras=cameras, camera_nodes=camera_nodes, size=size, workers=workers, refine=refine,
                              sim_people=people, board_clip=board_clip, plain_bus=plain_bus, gige=gige,
                              catalog_url=catalog, room=room)
            limits = WaitLimits(stall_s=wait_stall, overall_s=wait_limit)
        logging.getLogger("httpx").setLevel(logging.WARNING)
        stack = Stack(cfg)
        stop = stop_on_signals()
        kind = ("fake GigE Vision cameras (keypoints from the simulated detector)" if gige
                else "simulated cameras")
        typer.echo(f"starting gaitcap ({cameras} {kind}, detector, recorder, {workers} worker(s), "
                   f"API); logs in {stack.supervisor.log_dir}", err=True)
        if catalog or room:
            from gaitcap.services.catalog.pg_tools import shown_url

            typer.echo(f"catalog {shown_url(cfg.catalog)}, room {room or '(default)'}", err=True)
        typer.echo("bus: PLAIN TCP on loopback (--plain-bus): no authentication, any local process can use it"
                   if plain_bus else f"bus: mutual TLS, passwords and access control (keys in {bus_keys_dir(cfg)})",
                   err=True)
        try:
            with user_errors():
                stack.start()
            typer.echo(f"gaitcap clinic page: {stack.page_url}")
            typer.echo(f"sign in as: demo / {cfg.token}  (this terminal only; not logged)")
            typer.echo(f"API docs: {cfg.url}/docs")
            if auto or first_trial:
                ok = _one_trial(stack, seconds=seconds, refine=refine, limits=limits)
                if auto:
                    if not ok:
                        raise typer.Exit(code=1)
                    return
            typer.echo("Press Ctrl-C to stop.", err=True)
            stop.wait()
        finally:
            stack.stop()


def _one_trial(stack, *, seconds: float, refine: bool, limits) -> bool:
    """Record one simulated walk through the API, wait for its results (following the worker's stages
    within ``limits``) and print them; True if done, else False after saying what was still running."""
    from gaitcap.services.ops.auto_trial import format_metrics, run_trial

    with stack.client() as c:
        typer.echo(f"recording a {seconds:.0f} s walk ...", err=True)
        t = run_trial(c, subject_id="DEMO001", seconds=seconds, limits=limits)
        if t.state not in ("done", "done_with_warnings"):
            typer.echo(f"trial {t.trial_id} {t.state}: {t.error}; logs in {stack.supervisor.log_dir}", err=True)
            return False
        for warning in t.warnings:
            typer.echo(f"warning: {warning}", err=True)
        typer.echo(f"trial {t.trial_id}: results {_after(t.preliminary_s)} (preliminary) and "
                   f"{_after(t.refined_s)} (refined) after Stop")
        for stage in ("preliminary", "refined") if refine else ("preliminary",):
            typer.echo(format_metrics(c.get(f"/trials/{t.trial_id}/gait", params={"stage": stage}).json()))
    return True


def _after(seconds: float | None) -> str:
    return "never" if seconds is None else f"{seconds:.1f} s"
