"""``gaitcap apply-calibration CAL_ID``: reprocess the trials that used the calibration a version replaces,
under that version, through the worker's one processing path (each trial queued again in the catalog;
``--run`` also processes them here, else the running workers take them)."""

from __future__ import annotations

from pathlib import Path

import typer
from gaitcap.services.catalog.paths import DEFAULT_DATA_DIR
from gaitcap.services.cli._common import user_errors


def _process_queue(db, data_dir: Path, catalog: str, no_refine: bool) -> int:
    """Run a worker in this process until the job queue is empty; returns how many jobs it ran."""
    from gaitcap.services.catalog.paths import catalog_url
    from gaitcap.services.processing.worker import Worker, WorkerConfig

    worker = Worker(WorkerConfig(catalog_url=catalog_url(data_dir, catalog or None), data_dir=data_dir,
                                 refine=not no_refine), db=db)
    done = 0
    while worker.run_once():
        done += 1
    return done


def register(app: typer.Typer) -> None:
    @app.command("apply-calibration")
    def apply_calibration_cmd(
        calibration_id: str = typer.Argument(..., help="A calibration version (from `gaitcap refine-rig --data-dir`)."),
        data_dir: Path = typer.Option(DEFAULT_DATA_DIR, "--data-dir", envvar="GAITCAP_DATA_DIR"),
        catalog: str = typer.Option("", "--catalog", envvar="GAITCAP_CATALOG",
                                    help="SQLite path or SQLAlchemy URL (default DATA_DIR/catalog.sqlite)."),
        run: bool = typer.Option(False, "--run", help="Also process the queued trials in this process (else the "
                                 "running workers take them)."),
        no_refine: bool = typer.Option(False, "--no-refine", help="With --run: preliminary results only."),
    ) -> None:
        """Queue the trials that used the calibration CAL_ID replaces for processing again under CAL_ID."""
        from gaitcap.services.catalog.calibration_versions import apply_version, get_version
        from gaitcap.services.cli.refine_rig import open_existing_catalog

        with user_errors():
            db = open_existing_catalog(data_dir, catalog)
            queued, skipped = apply_version(db, calibration_id)
            replaced = get_version(db, calibration_id).replaces_id
            typer.echo(f"calibration {calibration_id} (replacing {replaced}): {len(queued)} trial(s) queued for "
                       f"processing again: {', '.join(queued) or 'none'}")
            if skipped:
                typer.echo(f"not queued (not finished yet; run again later): {', '.join(skipped)}", err=True)
            if run and queued:
                n = _process_queue(db, data_dir, catalog, no_refine)
                typer.echo(f"processed {n} job(s)")

