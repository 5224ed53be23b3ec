"""Scheduled backups of a SQLite catalog with SQLite's online backup API (consistent while the service
writes): ``<backup_dir>/catalog-YYYYmmdd-HHMMSS.sqlite`` (0600) every ``interval_s``, the newest ``keep``
kept. Other databases (a SQLAlchemy URL) are backed up with their own tools."""

from __future__ import annotations

import logging
import sqlite3
import threading
import time
from pathlib import Path

log = logging.getLogger(__name__)


def sqlite_path(catalog_url: str) -> Path | None:
    """The file of a SQLite catalog (a plain path or ``sqlite:///PATH``), else None."""
    if catalog_url.startswith("sqlite:///"):
        return Path(catalog_url[len("sqlite:///"):])
    return None if "://" in catalog_url else Path(catalog_url)


def _read_only_uri(path: Path) -> str:
    """A read-only SQLite URI of ``path``, quoted (a folder named with ``?``, ``#`` or ``%`` opens that file)."""
    return f"{Path(path).resolve().as_uri()}?mode=ro"


def backup_sqlite(src: Path, backup_dir: Path, *, keep: int) -> Path:
    """One consistent copy of ``src`` into ``backup_dir``; older copies beyond ``keep`` are removed."""
    backup_dir.mkdir(parents=True, exist_ok=True)
    backup_dir.chmod(0o700)
    now_ns = time.time_ns()  # names sort by time: the newest last
    dest = backup_dir / f"catalog-{time.strftime('%Y%m%d-%H%M%S', time.gmtime(now_ns / 1e9))}-{now_ns % 10**9:09d}.sqlite"
    tmp = dest.with_suffix(".part")
    tmp.touch(mode=0o600)
    with sqlite3.connect(_read_only_uri(src), uri=True) as source, sqlite3.connect(tmp) as target:
        source.backup(target)
    source.close()
    target.close()
    tmp.replace(dest)
    for old in sorted(backup_dir.glob("catalog-*.sqlite"))[:-keep]:
        old.unlink()
    return dest


class BackupSchedule:
    """A daemon thread backing the catalog up every ``interval_s`` (the first one after ``interval_s``)."""

    def __init__(self, src: Path, backup_dir: Path, *, interval_s: float, keep: int) -> None:
        self.src, self.backup_dir, self.interval_s, self.keep = src, backup_dir, interval_s, keep
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="catalog-backup", daemon=True)

    def start(self) -> BackupSchedule:
        self._thread.start()
        return self

    def _run(self) -> None:
        while not self._stop.wait(self.interval_s):
            try:
                log.info("catalog backup %s", backup_sqlite(self.src, self.backup_dir, keep=self.keep))
            except (OSError, sqlite3.Error) as exc:
                log.error("catalog backup failed: %s", exc)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=10)
