"""Backing up and restoring a PostgreSQL catalog with PostgreSQL's own ``pg_dump`` and ``pg_restore``.

:func:`dump` writes the whole catalog database in pg_dump's custom format (compressed, restorable table by
table) to a temporary name and renames it when complete; :func:`restore` loads such a file into an empty
database in one transaction (all or nothing). Both run the programs with the connection in ``PG*``
variables and the password in a passfile (:func:`gaitcap.services.catalog.pg_tools.libpq_environment`): the
command line holds only file and database names. A SQLite catalog is backed up by the API
(:mod:`gaitcap.api.backups`).

:func:`exported_snapshot` holds one read-only, repeatable-read transaction open and exports its snapshot:
a dump taken with it (``dump(..., snapshot=...)``) and every query on its connection see the same catalog,
so ``gaitcap backup`` copies the files of exactly the trials its dump holds while trials are written.
:func:`repoint_paths` moves a restored catalog's stored file paths into a new data folder.
"""

from __future__ import annotations

import contextlib
import logging
import os
import subprocess
from collections.abc import Iterator
from pathlib import Path

from gaitcap.services.catalog.pg_tools import is_postgres, libpq_environment, program, shown_url
from sqlalchemy import create_engine, text
from sqlalchemy.engine import Connection, make_url

log = logging.getLogger(__name__)


class BackupFailed(RuntimeError):
    """pg_dump or pg_restore failed (the message has the program's own words)."""


def _database(url: str) -> str:
    if not is_postgres(url):
        raise ValueError(f"catalog {shown_url(url)}: not a PostgreSQL URL (a SQLite catalog is backed up by the API)")
    return make_url(url).database or ""


def _run(argv: list[str], url: str, *, timeout_s: float) -> None:
    with libpq_environment(url) as env:
        done = subprocess.run(argv, env=env, capture_output=True, text=True, timeout=timeout_s)
    if done.returncode != 0:
        raise BackupFailed(f"{Path(argv[0]).name} on {shown_url(url)} failed ({done.returncode}): "
                           f"{done.stderr.strip()[-1000:]}")


def dump(url: str, path: str | os.PathLike, *, snapshot: str | None = None, timeout_s: float = 3600.0) -> Path:
    """The catalog database at ``url`` into ``path`` (pg_dump custom format); returns the path. ``snapshot``:
    an exported snapshot's id (:func:`exported_snapshot`) the dump sees, else the database as it is now."""
    database, path = _database(url), Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(path.name + ".partial")
    seen = [f"--snapshot={snapshot}"] if snapshot else []
    try:
        _run([program("pg_dump"), "--format=custom", "--no-owner", "--no-privileges", *seen, f"--file={partial}",
              database], url, timeout_s=timeout_s)
        os.replace(partial, path)
    finally:
        partial.unlink(missing_ok=True)
    log.info("catalog %s dumped to %s (%d bytes)", shown_url(url), path, path.stat().st_size)
    return path


def restore(path: str | os.PathLike, url: str, *, timeout_s: float = 3600.0) -> None:
    """Load the dump ``path`` into the empty database at ``url`` (one transaction: on an error nothing stays)."""
    database, path = _database(url), Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"catalog dump {path} does not exist")
    _run([program("pg_restore"), "--no-owner", "--no-privileges", "--exit-on-error", "--single-transaction",
          f"--dbname={database}", str(path)], url, timeout_s=timeout_s)
    log.info("catalog %s restored from %s", shown_url(url), path)


@contextlib.contextmanager
def exported_snapshot(url: str) -> Iterator[tuple[str, Connection]]:
    """(snapshot id, the connection whose transaction holds it): a read-only, repeatable-read transaction on
    ``url``'s database kept open until the block ends; a pg_dump given the id and every query on the
    connection see the catalog as it was when the block began."""
    _database(url)
    engine = create_engine(url, hide_parameters=True, isolation_level="REPEATABLE READ")
    try:
        with engine.connect() as conn:
            conn.exec_driver_sql("SET TRANSACTION READ ONLY")
            yield conn.execute(text("SELECT pg_export_snapshot()")).scalar_one(), conn
            conn.rollback()
    finally:
        engine.dispose()


#: (table, column) of every stored file path in the catalog
PATH_COLUMNS = (("trials", "recording_path"), ("calibrations", "recording_path"), ("results", "artifacts_json"))


def repoint_paths(url: str, old: str, new: str) -> int:
    """The catalog's stored file paths under the folder ``old`` moved under ``new`` (one transaction); rows
    changed."""
    _database(url)
    prefix, moved = old.rstrip("/") + "/", new.rstrip("/") + "/"
    engine = create_engine(url, hide_parameters=True)
    changed = 0
    try:
        with engine.begin() as conn:
            for table, column in PATH_COLUMNS:
                changed += conn.execute(text(f"UPDATE {table} SET {column} = replace({column}, :old, :new) "
                                             f"WHERE strpos({column}, :old) > 0"),
                                        {"old": prefix, "new": moved}).rowcount
    finally:
        engine.dispose()
    return changed
