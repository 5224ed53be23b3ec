"""``gaitcap backup``: the data folder (catalog, trials, accounts, audit trail) backed up while the clinic
runs; ``gaitcap restore``: a backup checked and restored into an empty data folder."""

from __future__ import annotations

from pathlib import Path

import typer
from gaitcap.services.catalog.paths import DEFAULT_DATA_DIR, catalog_url
from gaitcap.services.cli._common import user_errors


def register(app: typer.Typer) -> None:
    @app.command("backup")
    def backup(
        to: Path = typer.Option(..., "--to", help="The backup's folder (new or empty)."),
        data_dir: Path = typer.Option(DEFAULT_DATA_DIR, "--data-dir", envvar="GAITCAP_DATA_DIR"),
        catalog: str = typer.Option("", "--catalog", envvar="GAITCAP_CATALOG",
                                    help="SQLite path (default DATA_DIR/catalog.sqlite) or PostgreSQL URL "
                                         "(its password in ~/.pgpass or PGPASSFILE, never in the URL)."),
    ) -> None:
        """Back the data folder up while the stack runs: the catalog (SQLite's online backup, or pg_dump of a
        PostgreSQL one), every trial's files, board recordings, accounts and the audit trail, with a manifest
        of SHA-256 checksums."""
        from gaitcap.services.ops.backup import take_backup

        with user_errors():
            got = take_backup(data_dir, catalog_url(data_dir, catalog), to)
        typer.echo(f"backup {got.folder}: {len(got.trials)} trials, {len(got.files)} files, "
                   f"{got.total_bytes / 1e6:.1f} MB")

    @app.command("restore")
    def restore(
        backup_dir: Path = typer.Argument(..., help="A folder written by gaitcap backup."),
        data_dir: Path = typer.Option(..., "--data-dir", help="The empty data folder to restore into."),
        catalog: str = typer.Option("", "--catalog", help="A PostgreSQL backup: the empty database's URL to "
                                    "restore its catalog into (its password in ~/.pgpass or PGPASSFILE)."),
    ) -> None:
        """Check every file of a backup against its manifest, then restore it into an empty data folder (a
        SQLite catalog becomes DATA_DIR/catalog.sqlite, a PostgreSQL one goes into the empty database
        --catalog names; its file paths point into the new folder)."""
        from gaitcap.services.ops.backup import restore_backup

        with user_errors():
            got = restore_backup(backup_dir, data_dir, catalog or None)
        typer.echo(f"restored {len(got.trials)} trials, {len(got.files)} files into {got.folder}")
