"""Fixtures shared by every test folder: the session's throwaway PostgreSQL server; one JAX compilation cache
for the session's processes.

The session's processes (workers, ``gaitcap`` commands, the stacks' nodes) compile the same fits for the same
trial shapes again and again; with ``JAX_COMPILATION_CACHE_DIR`` set before JAX is imported here, they share one
persistent cache (JAX's own variable, which the workers honour: ``pipeline.compile_cache_dir``) in a folder
removed at the end. A cache the caller already set is left alone. The numbers are the same: a cached
executable is the one XLA compiled.
"""

import atexit
import os
import shutil
import tempfile

import pytest

if not os.environ.get("JAX_COMPILATION_CACHE_DIR"):
    _JAX_CACHE = tempfile.mkdtemp(prefix="gaitcap-tests-jax-")
    atexit.register(shutil.rmtree, _JAX_CACHE, ignore_errors=True)
    os.environ["JAX_COMPILATION_CACHE_DIR"] = _JAX_CACHE
    os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0.5")


@pytest.fixture(scope="session")
def postgres():
    """One throwaway PostgreSQL server for the whole session (gaitcap.services.ops.pg_server), its password
    file named in ``PGPASSFILE`` for this process and its children; stopped and removed at the end."""
    from gaitcap.services.ops.pg_server import LocalPostgres

    with LocalPostgres() as server, pytest.MonkeyPatch.context() as patch:
        for name, value in server.environment().items():
            patch.setenv(name, value)
        yield server
