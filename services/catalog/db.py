"""Opening the catalog database: SQLite by default (a file path), any SQLAlchemy URL otherwise.

SQLite is opened in WAL mode with a busy timeout and every transaction starts with ``BEGIN IMMEDIATE``,
so several processes (API, workers) can write without "database is locked" surprises and a lease is
taken atomically. The schema version is checked on open; an older catalog is upgraded
(:mod:`gaitcap.services.catalog.migrations`).

PostgreSQL (``postgresql+psycopg://user@host:port/db``): the password comes from the user's libpq password
file (``~/.pgpass`` or ``PGPASSFILE``), never from a URL that is logged or seen in a process listing (a URL
that carries one still works, with a warning; logs and errors show it as ``***``, :func:`shown_url`); TLS
to the server is set in the URL's query (``?sslmode=verify-full&sslrootcert=/etc/gaitcap/db-ca.pem``).
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import os
import signal
import sqlite3
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from gaitcap.services.catalog.migrations import STEPS, migration_problem
from gaitcap.services.catalog.models import SCHEMA_VERSION, Base, SchemaInfo
from gaitcap.services.catalog.pg_tools import shown_url
from sqlalchemy import Engine, create_engine, event, select, update
from sqlalchemy.engine import make_url
from sqlalchemy.orm import Session, sessionmaker

log = logging.getLogger(__name__)


class SchemaMismatch(RuntimeError):
    """The database was written by a different schema version of gaitcap."""


def database_url(path_or_url: str | Path) -> str:
    """A SQLAlchemy URL: URLs (``scheme://...``) pass through, anything else is a SQLite file path."""
    text = str(path_or_url)
    if "://" in text:
        return text
    path = Path(text).expanduser().resolve()
    path.parent.mkdir(parents=True, exist_ok=True)
    return f"sqlite:///{path}"


STOP_IN_WRITE_ENV = "GAITCAP_TEST_STOP_IN_WRITE"  # N: the process stops itself inside its Nth write (tests)


def _stop_in_write_at() -> int:
    """The write transaction inside which this process stops itself (SIGSTOP) holding SQLite's write lock,
    from ``GAITCAP_TEST_STOP_IN_WRITE`` (a test's fault: a worker stopped inside a catalog write); 0: never."""
    value = os.environ.get(STOP_IN_WRITE_ENV, "")
    if value and not value.isdigit():
        raise ValueError(f"{STOP_IN_WRITE_ENV}: a write count (1, 2, ...), got {value!r}")
    return int(value or 0)


def _sqlite_engine(url: str) -> Engine:
    engine = create_engine(url, connect_args={"timeout": 30, "check_same_thread": False})

    @event.listens_for(engine, "connect")
    def _on_connect(dbapi_conn, _record) -> None:
        dbapi_conn.isolation_level = None  # we issue BEGIN ourselves
        cur = dbapi_conn.cursor()
        _use_wal(cur)
        cur.execute("PRAGMA foreign_keys=ON")
        cur.execute("PRAGMA busy_timeout=30000")
        cur.execute("PRAGMA synchronous=NORMAL")
        cur.close()

    stop_at, writes = _stop_in_write_at(), itertools.count(1)

    @event.listens_for(engine, "begin")
    def _on_begin(conn) -> None:
        readonly = conn.get_execution_options().get("gaitcap_readonly", False)
        conn.exec_driver_sql("BEGIN" if readonly else "BEGIN IMMEDIATE")
        if stop_at and not readonly and next(writes) == stop_at:  # test hook: stopped holding the write lock
            log.warning("%s=%d: stopping this process (SIGSTOP) inside write transaction %d", STOP_IN_WRITE_ENV,
                        stop_at, stop_at)
            os.kill(os.getpid(), signal.SIGSTOP)

    return engine


WAL_SWITCH_WAIT_S = 30.0  # how long a connection waits for another to finish switching a new catalog to WAL


def _use_wal(cur: sqlite3.Cursor, *, wait_s: float = WAL_SWITCH_WAIT_S) -> None:
    """Put the catalog in WAL mode (kept in the file: only a new catalog's first connection switches it).

    The switch needs the file to itself and SQLite answers "database is locked" at once, without its busy
    timeout, while another process is opening the same new catalog (seen with 8 processes opening one at
    once): wait and try again, for at most ``wait_s`` (s)."""
    deadline = time.monotonic() + wait_s
    while True:
        try:
            if cur.execute("PRAGMA journal_mode").fetchone()[0].lower() != "wal":
                cur.execute("PRAGMA journal_mode=WAL")
            return
        except sqlite3.OperationalError as exc:
            if "locked" not in str(exc) or time.monotonic() > deadline:
                raise
            time.sleep(0.02)


@dataclass(frozen=True, eq=False)
class Catalog:
    """An open catalog: the engine and a session factory. Use :meth:`session` for one transaction."""

    url: str
    engine: Engine
    sessions: sessionmaker
    read_sessions: sessionmaker

    @contextlib.contextmanager
    def session(self) -> Iterator[Session]:
        """One transaction: committed on success, rolled back on error."""
        with self.sessions.begin() as s:
            yield s

    @contextlib.contextmanager
    def reading(self) -> Iterator[Session]:
        """A read-only transaction (SQLite: a plain BEGIN, so readers never queue behind writers)."""
        with self.read_sessions.begin() as s:
            yield s

    @property
    def shown_url(self) -> str:
        """The URL as logs and errors show it (a password as ``***``)."""
        return shown_url(self.url)

    def close(self) -> None:
        self.engine.dispose()


def open_catalog(path_or_url: str | Path, *, create: bool = True) -> Catalog:
    """Open (and by default create) the catalog at a SQLite path or a SQLAlchemy URL.

    An older catalog is upgraded first; raises SchemaMismatch when the stored schema version differs from
    :data:`SCHEMA_VERSION` and cannot be upgraded here.
    """
    url = database_url(path_or_url)
    if make_url(url).password is not None:
        log.warning("catalog %s: the URL carries a password, which process listings and shell histories show; "
                    "put it in a libpq password file (~/.pgpass or PGPASSFILE) instead", shown_url(url))
    engine = _sqlite_engine(url) if url.startswith("sqlite") else create_engine(url, pool_pre_ping=True,
                                                                                hide_parameters=True)
    reader = engine.execution_options(gaitcap_readonly=True)
    catalog = Catalog(url=url, engine=engine, sessions=sessionmaker(engine, expire_on_commit=False),
                      read_sessions=sessionmaker(reader, expire_on_commit=False))
    with _one_opening_at_a_time(engine):
        if create:
            Base.metadata.create_all(engine)
        _check_version(catalog)
    return catalog


_OPENING_LOCK = 0x6761_6974  # "gait": the PostgreSQL advisory lock of opening (creating, upgrading) a catalog


@contextlib.contextmanager
def _one_opening_at_a_time(engine: Engine) -> Iterator[None]:
    """PostgreSQL: processes opening the same new catalog at once (a stack's API and workers, two rooms) take
    turns creating and upgrading its tables (concurrent CREATE TABLEs collide there). SQLite's write
    transactions already take turns."""
    if engine.dialect.name != "postgresql":
        yield
        return
    with engine.connect() as conn:
        conn.exec_driver_sql(f"SELECT pg_advisory_lock({_OPENING_LOCK})")
        try:
            yield
        finally:
            conn.exec_driver_sql(f"SELECT pg_advisory_unlock({_OPENING_LOCK})")
            conn.commit()


def _check_version(catalog: Catalog) -> None:
    with catalog.session() as s:
        row = s.get(SchemaInfo, "version")
        if row is None:
            s.add(SchemaInfo(key="version", value=str(SCHEMA_VERSION)))
            s.add(SchemaInfo(key="created_at", value=f"{time.time():.3f}"))
            return
        version = int(row.value)
    if version != SCHEMA_VERSION:
        _upgrade(catalog, version)


def _upgrade(catalog: Catalog, version: int) -> None:
    problem = migration_problem(catalog.engine.dialect.name, version, SCHEMA_VERSION)
    if problem:
        raise SchemaMismatch(f"catalog {catalog.shown_url}: {problem}")
    for step in range(version, SCHEMA_VERSION):
        with catalog.engine.begin() as conn:  # one transaction per step
            STEPS[step](conn)
            conn.execute(update(SchemaInfo).where(SchemaInfo.key == "version").values(value=str(step + 1)))
        log.info("catalog %s: upgraded from schema version %d to %d", catalog.shown_url, step, step + 1)


def schema_version(catalog: Catalog) -> int:
    with catalog.session() as s:
        return int(s.scalars(select(SchemaInfo.value).where(SchemaInfo.key == "version")).one())
