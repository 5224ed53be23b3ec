"""``gaitcap worker``: the worker (takes jobs from the catalog's job table: recorded trials to process,
board recordings to calibrate)."""

from __future__ import annotations

from pathlib import Path

import typer
from gaitcap.services.catalog.paths import DEFAULT_DATA_DIR, catalog_url
from gaitcap.services.cli._common import stop_on_signals, user_errors
from gaitcap.services.cli.detect import COMPLETE_WITH_HELP, ONLY_MISSING_HELP, completion_plan


def room_fetch(pairs: list[str], node: str, retry_s: float):
    """``--fetch-bus ROOM=BUSFILE`` options -> the worker's RoomFetch (None when there are none)."""
    if not pairs:
        return None
    from gaitcap.services.bus.session import load_bus_config
    from gaitcap.services.processing.room_fetch import RoomFetch

    buses = {}
    for pair in pairs:
        room, sep, path = pair.partition("=")
        if not sep or not path:
            raise ValueError(f"--fetch-bus: {pair!r} is not ROOM=BUSFILE")
        buses[room] = load_bus_config(path)
    return RoomFetch(buses=buses, node=node, retry_s=retry_s)


def register(app: typer.Typer) -> None:
    @app.command()
    def worker(
        data_dir: Path = typer.Option(DEFAULT_DATA_DIR, "--data-dir", envvar="GAITCAP_DATA_DIR"),
        catalog: str = typer.Option("", "--catalog", envvar="GAITCAP_CATALOG",
                                    help="SQLite path or SQLAlchemy URL (default DATA_DIR/catalog.sqlite)."),
        worker_id: str = typer.Option("", "--id", help="Worker name (default host-pid)."),
        store: Path | None = typer.Option(None, "--store", envvar="GAITCAP_STORE",
                                          help="This host's mount of the rooms' shared store (the folder holding "
                                               "trials/): where a recording is read when the catalog's path is not "
                                               "on this host; checked against the checksum taken at Stop."),
        fetch_bus: list[str] = typer.Option([], "--fetch-bus", help="ROOM=BUSFILE (one per room; '=BUSFILE' the "
                                            "default room): without the shared store, fetch a room's recordings "
                                            "from its recorder over that bus, verified by checksum."),
        fetch_node: str = typer.Option("worker-fetch", "--fetch-node",
                                       help="The identity this worker joins the rooms' buses as (a worker-* name)."),
        fetch_retry_s: float = typer.Option(120.0, "--fetch-retry-s",
                                            help="A fetch from a room's recorder that fails for a reason that may "
                                                 "pass (the recorder unreachable or restarting, a chunk timed out, "
                                                 "a copy failing its checksum) is tried again until this many "
                                                 "seconds pass without a new byte; then the trial fails."),
        lease_s: float = typer.Option(10.0, "--lease", help="Job lease (s); renewed every third of it."),
        no_refine: bool = typer.Option(False, "--no-refine", help="Preliminary results only."),
        bus: Path | None = typer.Option(None, "--bus", envvar="GAITCAP_BUS", help="Bus file (JSON5)."),
        no_bus: bool = typer.Option(False, "--no-bus", help="Do not declare this worker alive on the bus."),
        node: str = typer.Option("worker", "--node", help="Bus node name of this worker."),
        warm_up: bool = typer.Option(True, "--warm-up/--no-warm-up", help="Compile JAX code at start."),
        complete_with: str = typer.Option("none", "--complete-with", help=COMPLETE_WITH_HELP),
        complete_model: Path | None = typer.Option(None, "--complete-model", help="Its model (e.g. mediapipe heavy)."),
        complete_param: list[str] = typer.Option([], "--complete-param", help="Its other config field KEY=VALUE."),
        complete_workers: int | None = typer.Option(None, "--complete-workers",
                                                    help="Its processes (default: one per CPU core)."),
        complete_only_missing: bool = typer.Option(False, "--complete-only-missing", help=ONLY_MISSING_HELP),
        max_rss_mb: float = typer.Option(3000.0, "--max-rss-mb", help="After a job, exit (code 75, to be restarted by "
                                         "the supervisor or systemd) when resident memory is above this (MB)."),
        gpu: bool = typer.Option(False, "--gpu", help="Run the completion detection (ONNX) on onnxruntime's CUDA "
                                 "provider and the JAX fits on a GPU; refused on a host without one."),
        gpu_fallback: bool = typer.Option(False, "--gpu-fallback", help="With --gpu: where the GPU is missing, "
                                          "run on the CPU (said as a warning) instead of refusing."),
        rerun_images_hz: float = typer.Option(5.0, "--rerun-images-hz",
                                              help="Images per second and camera in the trial's .rrd (0: none)."),
    ) -> None:
        """Process recorded trials (preliminary then refined gait metrics, files, progress in the catalog) and
        compute the calibrations of stopped board recordings, as jobs taken from the catalog under a lease."""
        from gaitcap.services.processing.pipeline import compile_cache_dir
        from gaitcap.services.processing.viewers.rerun_trial import RerunSettings
        from gaitcap.services.processing.worker import Worker, WorkerConfig, warm_worker

        with user_errors():
            from gaitcap.services.processing.devices import DeviceChoice, apply_plan, host_plan

            choice = DeviceChoice(gpu=gpu, fallback=gpu_fallback)
            plan = host_plan(choice)
            completion = apply_plan(plan, completion_plan(complete_with, complete_model, complete_param,
                                                          complete_workers, only_missing=complete_only_missing),
                                    choice)
            cfg = WorkerConfig(catalog_url=catalog_url(data_dir, catalog), data_dir=data_dir,
                               lease_s=lease_s, refine=not no_refine, rerun=RerunSettings(image_rate_hz=rerun_images_hz),
                               store=store, fetch=room_fetch(fetch_bus, fetch_node, fetch_retry_s), completion=completion, max_rss_mb=max_rss_mb,
                               **({"worker_id": worker_id} if worker_id else {}))
            session = None
            if not no_bus:  # the worker is alive on the bus (the API's health); its progress is in the catalog
                from gaitcap.services.bus.session import declare_alive, default_bus_config, open_session

                bus_cfg = default_bus_config(bus)
                session = open_session(bus_cfg, node)
                _token = declare_alive(session, bus_cfg, node)  # noqa: F841  (held while running)
            w = Worker(cfg)
        def _abandon(signum: int) -> None:
            if w.busy:  # do not finish a long fit: the job's lease expires and another worker redoes it
                raise SystemExit(128 + signum)

        stop = stop_on_signals(_abandon)
        for line in plan.lines(None if completion is None else completion.detector_name):
            typer.echo(f"worker {cfg.worker_id}: {line}", err=True)
        if warm_up:
            typer.echo(f"worker {cfg.worker_id}: warming up (compiling) ...", err=True)
            typer.echo(f"worker {cfg.worker_id}: warm in {warm_worker(cache_dir=compile_cache_dir(data_dir)):.1f} s", err=True)
        typer.echo(f"worker {cfg.worker_id}: ready", err=True)
        ended = w.run(stop)
        if session is not None:
            session.close()
        if ended == "recycle":  # grown too big: a fresh process takes over (EX_TEMPFAIL, so systemd restarts it)
            raise typer.Exit(75)
