"""``gaitcap reprocess`` and ``gaitcap sweep``: re-run methods over many recorded trials (local process
pool by default, a Ray cluster with ``--ray``); results go to the catalog keyed by (trial, method,
parameters), pairs already done are skipped, so an interrupted run resumes when started again."""

from __future__ import annotations

from pathlib import Path

import typer
from gaitcap.services.catalog.paths import DEFAULT_DATA_DIR, catalog_url
from gaitcap.services.cli._common import progress, user_errors

METHOD_HELP = ("Method (repeatable): NAME or NAME@PRESET, optionally followed by :key=value,key=value; e.g. "
               "robust, robust:sigma_mm=100, implicit:gamma=0.3,huber_cut_px=10, explicit@paper:steps=2000.")


def _executor(ray: str, workers: int, ray_retries: int):
    from gaitcap.services.research.executors import Inline, LocalPool, RayCluster

    if ray:
        return RayCluster(address=ray, max_retries=ray_retries, local_cpus=workers or None)
    return Inline() if workers == 0 else LocalPool(workers=workers)


def _run(db, data_dir: Path, trials: str, specs, *, ray: str, workers: int, ray_retries: int,
         gpus_per_fit: float | None, retry_failed: bool, write_files: bool = True):
    """Plan, run with a progress bar, return (plan, summary)."""
    from gaitcap.services.processing.pipeline import compile_cache_dir
    from gaitcap.services.research.reprocess import TrialSelection, plan_reprocess, run_plan, task_resources

    in_process = not ray and workers == 0
    plan = plan_reprocess(db, data_dir, TrialSelection.parse(trials), specs, retry_failed=retry_failed,
                          write_files=write_files, compile_cache=None if in_process else compile_cache_dir(data_dir))
    for tid in plan.missing:
        typer.echo(f"warning: trial {tid}: recording file missing; left out", err=True)
    typer.echo(f"{len(plan.trials)} trial(s) x {len(plan.specs)} method(s): {plan.already_done} already done, "
               f"{len(plan.tasks)} to compute", err=True)
    with _executor(ray, workers, ray_retries).open() as executor, progress(len(plan.tasks), "reprocess", "task") as bar:
        gpus = gpus_per_fit
        if gpus is None:
            gpus = 1.0 if getattr(executor, "cluster_gpus", lambda: 0.0)() > 0 else 0.0

        def on_outcome(outcome) -> None:
            bar.update(1)
            if outcome.status == "failed":
                bar.write(f"failed: {outcome.trial_id} {outcome.method}: {outcome.error}")

        summary = run_plan(plan, executor, on_outcome=on_outcome, resources=task_resources(gpus))
    typer.echo(f"computed {summary.computed}, skipped {summary.skipped} (already done), failed {summary.failed}",
               err=True)
    return plan, summary


def register(app: typer.Typer) -> None:
    common = {
        "data_dir": typer.Option(DEFAULT_DATA_DIR, "--data-dir", envvar="GAITCAP_DATA_DIR",
                                 help="Trial files (DATA_DIR/trials/<id>/recording.mcap)."),
        "catalog": typer.Option("", "--catalog", envvar="GAITCAP_CATALOG",
                                help="SQLite path or SQLAlchemy URL (default DATA_DIR/catalog.sqlite)."),
        "trials": typer.Option("all", "--trials",
                               help="Comma-separated shell patterns on trial id, subject or subject/session."),
        "ray": typer.Option("", "--ray", help="Ray address (auto, ray://HOST:10001, or local); default: "
                                              "a local process pool."),
        "workers": typer.Option(2, "--workers", help="Local worker processes (0: run in this process); "
                                                     "with --ray local: the CPUs of the local Ray."),
        "ray_retries": typer.Option(3, "--ray-retries", help="Ray: retries of a task whose worker died."),
        "gpus_per_fit": typer.Option(None, "--gpus-per-fit",
                                     help="Ray: GPUs per trajectory fit (default 1 when the cluster has GPUs)."),
        "retry_failed": typer.Option(False, "--retry-failed", help="Compute failed pairs again."),
    }

    @app.command()
    def reprocess(
        method: list[str] = typer.Option(..., "--method", "-m", help=METHOD_HELP),
        data_dir: Path = common["data_dir"], catalog: str = common["catalog"], trials: str = common["trials"],
        ray: str = common["ray"], workers: int = common["workers"], ray_retries: int = common["ray_retries"],
        gpus_per_fit: float | None = common["gpus_per_fit"], retry_failed: bool = common["retry_failed"],
        json_out: bool = typer.Option(False, "--json", help="Print the run's counts as one JSON object."),
    ) -> None:
        """Re-run reconstruction + gait analysis of recorded trials under one or more methods."""
        import json

        from gaitcap.services import catalog as cat
        from gaitcap.services.research.method_specs import parse_method

        with user_errors():
            specs = [parse_method(m) for m in method]
            db = cat.open_catalog(catalog_url(data_dir, catalog))
            plan, summary = _run(db, data_dir, trials, specs, ray=ray, workers=workers, ray_retries=ray_retries,
                                 gpus_per_fit=gpus_per_fit, retry_failed=retry_failed)
        if json_out:
            typer.echo(json.dumps({"trials": len(plan.trials), "methods": [s.name for s in plan.specs],
                                   "computed": summary.computed, "skipped": summary.skipped,
                                   "failed": summary.failed}))
        if summary.failed:
            raise typer.Exit(code=1)

    @app.command()
    def sweep(
        grid: Path = typer.Option(..., "--grid", help="Grid of methods and hyperparameters (JSON or TOML)."),
        out: Path = typer.Option(..., "--out", help="Folder for sweep.csv, sweep.md and sweep.json."),
        data_dir: Path = common["data_dir"], catalog: str = common["catalog"], trials: str = common["trials"],
        ray: str = common["ray"], workers: int = common["workers"], ray_retries: int = common["ray_retries"],
        gpus_per_fit: float | None = common["gpus_per_fit"], retry_failed: bool = common["retry_failed"],
    ) -> None:
        """Run a grid of methods over trials and write the summary table (the paper's appendix layout)."""
        from gaitcap.services import catalog as cat
        from gaitcap.services.research.sweep import load_grid, summarize, write_tables

        with user_errors():
            specs = load_grid(grid)
            db = cat.open_catalog(catalog_url(data_dir, catalog))
            plan, _ = _run(db, data_dir, trials, specs, ray=ray, workers=workers, ray_retries=ray_retries,
                           gpus_per_fit=gpus_per_fit, retry_failed=retry_failed)
            table = summarize(db, [t.trial_id for t in plan.trials], plan.specs)
            paths = write_tables(table, out)
        typer.echo(table.markdown())
        typer.echo(f"wrote {', '.join(str(p) for p in paths)}", err=True)
