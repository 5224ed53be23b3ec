"""The catalog's tests run on both databases gaitcap supports: a SQLite file and a PostgreSQL database on
the session's throwaway server (``postgres``, tests/services/conftest.py).

``catalog_url``: an empty catalog's location. On PostgreSQL the tests share one database, emptied after
each test (TRUNCATE: far quicker than a database each); ``fresh_catalog_url`` is a database of its own, for
tests that change the schema (migrations). ``raw_sql(url, script)`` runs SQL statements as they are (the
old schemas the migration tests build), outside the catalog's code.
"""

import itertools

import pytest
from gaitcap.services.catalog.models import Base
from sqlalchemy import create_engine

BACKENDS = ("sqlite", "postgresql")
_numbers = itertools.count()


def raw_sql(url: str, script: str, params: dict | None = None) -> list:
    """Run ``script`` (statements separated by ';') in one transaction; the rows of the last statement."""
    engine = create_engine(url if "://" in url else f"sqlite:///{url}")
    try:
        with engine.begin() as conn:
            rows = []
            for statement in (s for s in script.split(";") if s.strip()):
                result = conn.exec_driver_sql(statement, params) if params else conn.exec_driver_sql(statement)
                rows = result.fetchall() if result.returns_rows else []
            return rows
    finally:
        engine.dispose()


@pytest.fixture(scope="session")
def shared_pg_catalog(postgres):
    from gaitcap.services import catalog as cat

    url = postgres.create_database("shared_catalog")
    cat.open_catalog(url).close()  # the tables exist for the TRUNCATE after each test
    return url


@pytest.fixture(params=BACKENDS)
def backend(request):
    return request.param


@pytest.fixture
def catalog_url(backend, tmp_path, request):
    if backend == "sqlite":
        yield str(tmp_path / "catalog.sqlite")
        return
    url = request.getfixturevalue("shared_pg_catalog")
    yield url
    tables = ", ".join(t.name for t in Base.metadata.sorted_tables)
    raw_sql(url, f"SET lock_timeout = '10s'; TRUNCATE {tables} RESTART IDENTITY CASCADE")


@pytest.fixture
def fresh_catalog_url(backend, tmp_path, request):
    if backend == "sqlite":
        return str(tmp_path / "fresh.sqlite")
    return request.getfixturevalue("postgres").create_database(f"fresh_{next(_numbers)}")
