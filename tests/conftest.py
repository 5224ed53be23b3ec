"""Fixtures shared by every test folder: the session's throwaway PostgreSQL server."""

import pytest


@pytest.fixture(scope="session")
def postgres():
    """One throwaway PostgreSQL server for the whole session (gaitcap.services.ops.pg_server), its password
    file named in ``PGPASSFILE`` for this process and its children; stopped and removed at the end."""
    from gaitcap.services.ops.pg_server import LocalPostgres

    with LocalPostgres() as server, pytest.MonkeyPatch.context() as patch:
        for name, value in server.environment().items():
            patch.setenv(name, value)
        yield server
