"""A clinic's whole data folder backed up while it runs, and restored into an empty one.

:func:`take_backup` copies, into a new folder:

- the catalog: a SQLite one with SQLite's online backup API (``catalog.sqlite``), a PostgreSQL one with
  ``pg_dump`` (``catalog.dump``, :mod:`gaitcap.services.catalog.pg_backup`; the password never on a command
  line or in the manifest); either is one consistent snapshot, taken while the API and workers keep writing;
- the files of every trial in that snapshot (``trials/<id>/``: the recording, each stage's results, the
  reports, kinematics), the calibrations' board recordings under the data folder, the accounts file and the
  audit trail (``audit.log``, up to its last whole line: it may be appended meanwhile);
- ``manifest.json`` last (written whole, so a backup without one is incomplete): the catalog's file and
  schema version, the data folder it came from, each trial's state in the snapshot and, for every file copied,
  its size (bytes) and SHA-256.

Left out: logs, the bus keys (a restored stack makes its own), the JAX compilation cache and the
scheduled catalog copies (``backups/``). A file that changes while it is copied is read again (up to 3
times) until two reads agree; a trial still recording or processing in the snapshot is copied as it was,
and its state says so. The trials listed are the snapshot's: a PostgreSQL dump is taken from a snapshot
exported by the transaction that lists them (:func:`~gaitcap.services.catalog.pg_backup.exported_snapshot`).

:func:`restore_backup` checks every file against the manifest first (a damaged backup restores nothing
and names the file), refuses a data folder that is not empty, copies the files in, and points the
catalog's file paths (recordings, result files, board recordings) from the old data folder to the new one.
A PostgreSQL backup is restored into an empty database (``catalog_url``; ``pg_restore`` in one transaction,
so a database that is not empty is refused and left as it was) before its files are copied.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import os
import shutil
import sqlite3
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from gaitcap.acquisition.fileio import atomic_write_text
from gaitcap.services.catalog import pg_backup
from gaitcap.services.catalog.pg_tools import PostgresMissing, is_postgres

log = logging.getLogger(__name__)
MANIFEST = "manifest.json"
CATALOG = "catalog.sqlite"
PG_CATALOG = "catalog.dump"  # a PostgreSQL catalog, pg_dump's custom format
AUDIT = "audit.log"
KEPT_FILES = ("accounts.json",)  # besides the catalog, trials, board recordings and the audit trail
CHUNK = 1 << 20


class BackupError(ValueError):
    """A backup that cannot be taken or restored, with the file and the reason."""


@dataclass(frozen=True)
class Backup:
    """A finished backup: its folder, the trials it holds (id -> state in the snapshot), its files
    (path relative to the backup -> (bytes, sha256 hex)) and its total size (bytes)."""

    folder: Path
    trials: dict[str, str]
    files: dict[str, tuple[int, str]]

    @property
    def total_bytes(self) -> int:
        return sum(size for size, _ in self.files.values())


def sha256_of(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        while block := f.read(CHUNK):
            digest.update(block)
    return digest.hexdigest()


def sqlite_file(catalog_url: str) -> Path:
    """The file of a SQLite catalog (a path or ``sqlite:///PATH``); BackupError for another database
    (PostgreSQL's is dumped instead)."""
    if catalog_url.startswith("sqlite:///"):
        return Path(catalog_url[len("sqlite:///"):])
    if "://" in catalog_url:
        raise BackupError(f"catalog {catalog_url.split('://')[0]}://...: back it up with its own tools "
                          "(this backup copies a SQLite or PostgreSQL catalog)")
    return Path(catalog_url)


def _snapshot_catalog(src: Path, dest: Path) -> None:
    """SQLite's online backup of ``src`` into ``dest`` (consistent while others write)."""
    if not src.is_file():
        raise BackupError(f"catalog {src}: no such file")
    with sqlite3.connect(f"{src.resolve().as_uri()}?mode=ro", uri=True) as source, sqlite3.connect(dest) as target:
        source.backup(target)
    source.close()
    target.close()


def _copy_settled(src: Path, dest: Path, attempts: int = 3) -> tuple[int, str]:
    """Copy ``src`` to ``dest`` until the copy's checksum equals the source's afterwards; (bytes, sha256)."""
    dest.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
    for _ in range(attempts):
        shutil.copyfile(src, dest)
        os.chmod(dest, 0o600)  # patient data
        got = sha256_of(dest)
        if sha256_of(src) == got:
            return dest.stat().st_size, got
    raise BackupError(f"{src}: changed while it was copied, {attempts} times")


def _unfinished(path: Path) -> bool:
    """A file still being written: a recording in progress (``.part``), an atomic writer's temporary
    (``.NAME.XXXX``) or another ``.tmp``."""
    return path.name.endswith((".tmp", ".part")) or path.name.startswith(".")


def _copy_audit(src: Path, dest: Path) -> tuple[int, str]:
    """The audit trail up to its last whole line (lines are appended while it is read)."""
    data = src.read_bytes()
    data = data[: data.rfind(b"\n") + 1]
    dest.write_bytes(data)
    os.chmod(dest, 0o600)
    return len(data), hashlib.sha256(data).hexdigest()


def _facts(rows) -> tuple[int, dict[str, str], list[str]]:
    """(schema version, trial id -> state, board recording paths) from ``rows(sql)``, the snapshot's rows."""
    version = int(list(rows("SELECT value FROM schema_info WHERE key = 'version'"))[0][0])
    trials = {r[0]: r[1] for r in rows("SELECT id, state FROM trials ORDER BY created_at")}
    boards = [r[0] for r in rows("SELECT recording_path FROM calibrations WHERE recording_path != ''")]
    return version, trials, boards


def _snapshot_facts(catalog: Path) -> tuple[int, dict[str, str], list[str]]:
    """(schema version, trial id -> state, board recording paths) as the SQLite snapshot holds them."""
    with sqlite3.connect(f"{catalog.resolve().as_uri()}?mode=ro", uri=True) as con:
        facts = _facts(con.execute)
    con.close()
    return facts


def _sqlite_catalog(catalog_url: str, dest: Path) -> tuple[str, tuple[int, dict[str, str], list[str]]]:
    _snapshot_catalog(sqlite_file(catalog_url), dest / CATALOG)
    os.chmod(dest / CATALOG, 0o600)
    return CATALOG, _snapshot_facts(dest / CATALOG)


@contextlib.contextmanager
def _pg_errors() -> Iterator[None]:
    """pg_dump / pg_restore failing, or not installed, as a BackupError (their own words; no password)."""
    try:
        yield
    except (pg_backup.BackupFailed, PostgresMissing) as exc:
        raise BackupError(str(exc)) from exc


def _postgres_catalog(catalog_url: str, dest: Path) -> tuple[str, tuple[int, dict[str, str], list[str]]]:
    """pg_dump of the catalog from the snapshot whose trials are listed (the dump holds exactly those)."""
    with _pg_errors(), pg_backup.exported_snapshot(catalog_url) as (snapshot, conn):
        facts = _facts(conn.exec_driver_sql)
        pg_backup.dump(catalog_url, dest / PG_CATALOG, snapshot=snapshot)
    os.chmod(dest / PG_CATALOG, 0o600)
    return PG_CATALOG, facts


def take_backup(data_dir: Path, catalog_url: str, dest: Path) -> Backup:
    """Back the data folder ``data_dir`` (with its catalog at ``catalog_url``) up into the new folder ``dest``."""
    data_dir, dest = Path(data_dir).resolve(), Path(dest)
    if dest.exists() and any(dest.iterdir()):
        raise BackupError(f"backup folder {dest}: not empty")
    dest.mkdir(parents=True, exist_ok=True, mode=0o700)
    t0 = time.time()
    snapshot = _postgres_catalog if is_postgres(catalog_url) else _sqlite_catalog
    catalog, (version, trials, boards) = snapshot(catalog_url, dest)
    files = {catalog: ((dest / catalog).stat().st_size, sha256_of(dest / catalog))}
    for tid in trials:
        folder = data_dir / "trials" / tid
        for path in sorted(p for p in folder.rglob("*") if p.is_file() and not _unfinished(p)):
            rel = path.relative_to(data_dir).as_posix()
            try:
                files[rel] = _copy_settled(path, dest / rel)
            except FileNotFoundError:  # removed (or replaced and renamed) since it was listed: not kept
                log.info("backup: %s went away while the backup ran; left out", rel)
                (dest / rel).unlink(missing_ok=True)
    for board in boards:
        path = Path(board)
        if path.is_file() and path.resolve().is_relative_to(data_dir) and not path.resolve().is_relative_to(
                data_dir / "trials"):
            rel = path.resolve().relative_to(data_dir).as_posix()
            files[rel] = _copy_settled(path, dest / rel)
    for name in KEPT_FILES:
        if (data_dir / name).is_file():
            files[name] = _copy_settled(data_dir / name, dest / name)
    if (data_dir / AUDIT).is_file():
        files[AUDIT] = _copy_audit(data_dir / AUDIT, dest / AUDIT)
    manifest = {"taken_at": t0, "catalog": catalog, "schema_version": version, "data_dir": str(data_dir), "trials": trials,
                "files": {rel: {"bytes": size, "sha256": digest} for rel, (size, digest) in sorted(files.items())}}
    atomic_write_text(dest / MANIFEST, json.dumps(manifest, indent=1))
    log.info("backup %s: %d trials, %d files, %.1f MB in %.1f s", dest, len(trials), len(files),
             sum(s for s, _ in files.values()) / 1e6, time.time() - t0)
    return Backup(dest, trials, files)


def read_manifest(folder: Path) -> dict:
    path = Path(folder) / MANIFEST
    if not path.is_file():
        raise BackupError(f"backup {folder}: no {MANIFEST} (not a backup, or one that did not finish)")
    return json.loads(path.read_text())


def verify_backup(folder: Path) -> Backup:
    """Every file of the backup against its manifest (size and SHA-256); BackupError naming the first
    file missing or different."""
    folder = Path(folder)
    manifest = read_manifest(folder)
    files = {}
    for rel, want in manifest["files"].items():
        path = folder / rel
        if not path.is_file():
            raise BackupError(f"backup {folder}: {rel} is missing")
        got = (path.stat().st_size, sha256_of(path))
        if got != (want["bytes"], want["sha256"]):
            raise BackupError(f"backup {folder}: {rel} differs from its manifest ({got[0]} bytes, sha256 "
                              f"{got[1][:12]}..., expected {want['bytes']} bytes, {want['sha256'][:12]}...)")
        files[rel] = got
    return Backup(folder, dict(manifest["trials"]), files)


def _repoint_paths(catalog: Path, old: str, new: str) -> int:
    """The SQLite catalog's stored file paths under ``old`` moved under ``new``; rows changed."""
    prefix = old.rstrip("/") + "/"
    changed = 0
    with sqlite3.connect(catalog) as con:
        for table, column in pg_backup.PATH_COLUMNS:
            cur = con.execute(f"UPDATE {table} SET {column} = replace({column}, ?, ?) WHERE instr({column}, ?) > 0",
                              (prefix, new.rstrip("/") + "/", prefix))
            changed += cur.rowcount
    con.close()
    return changed


def _target_catalog(folder: Path, catalog: str, catalog_url: str | None) -> None:
    """BackupError when the backup's catalog and the database to restore into do not go together."""
    if catalog == PG_CATALOG and not (catalog_url and is_postgres(catalog_url)):
        raise BackupError(f"backup {folder}: holds a PostgreSQL catalog ({PG_CATALOG}); name the empty "
                          "PostgreSQL database to restore it into (--catalog postgresql+psycopg://HOST/DATABASE)")
    if catalog == CATALOG and catalog_url:
        raise BackupError(f"backup {folder}: holds a SQLite catalog, restored as DATA_DIR/{CATALOG}; it is not "
                          "restored into another database")


def restore_backup(folder: Path, data_dir: Path, catalog_url: str | None = None) -> Backup:
    """Restore the backup in ``folder`` into the empty (or new) data folder ``data_dir``; a SQLite catalog
    becomes ``data_dir/catalog.sqlite``, a PostgreSQL one is restored into the empty database at
    ``catalog_url`` first."""
    backup = verify_backup(folder)
    data_dir = Path(data_dir)
    catalog = read_manifest(folder).get("catalog", CATALOG)
    _target_catalog(Path(folder), catalog, catalog_url)
    if data_dir.exists() and any(data_dir.iterdir()):
        raise BackupError(f"data folder {data_dir}: not empty (restore into an empty folder)")
    if catalog == PG_CATALOG:
        with _pg_errors():
            pg_backup.restore(Path(folder) / PG_CATALOG, catalog_url)
    data_dir.mkdir(parents=True, exist_ok=True)
    for rel in (r for r in backup.files if r != PG_CATALOG):
        target = data_dir / rel
        target.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
        shutil.copyfile(Path(folder) / rel, target)
        os.chmod(target, 0o600)  # patient data, as the clinic's own files
    manifest = read_manifest(folder)
    old, new = manifest["data_dir"], str(data_dir.resolve())
    moved = pg_backup.repoint_paths(catalog_url, old, new) if catalog == PG_CATALOG else _repoint_paths(
        data_dir / CATALOG, old, new)
    log.info("restored %s into %s: %d trials, %d files, %d stored paths moved", folder, data_dir,
             len(backup.trials), len(backup.files), moved)
    return Backup(data_dir, backup.trials, backup.files)
