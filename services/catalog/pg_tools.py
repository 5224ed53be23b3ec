"""PostgreSQL's own programs (``pg_dump``, ``pg_restore``, ``initdb``, ``pg_ctl``) and how gaitcap hands them a
catalog URL without putting a password where others can read it.

A catalog URL names the server, the user and the database; its password belongs in a libpq password file
(``~/.pgpass`` or the file ``PGPASSFILE`` names, mode 0600), which the driver (psycopg, on libpq) and these
programs read themselves. :func:`libpq_environment` turns a URL into the ``PG*`` variables a program reads
(never its command line, which every user of the host can list); a URL that does carry a password has it
written to a passfile of its own (:func:`passfile_for`), never into a variable or an argument.
:func:`shown_url` is the only form of a URL that goes into a log or an error.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

from sqlalchemy.engine import URL, make_url

#: URL query parameters passed to libpq as environment variables (TLS and time-outs).
QUERY_VARIABLES = {"sslmode": "PGSSLMODE", "sslrootcert": "PGSSLROOTCERT", "sslcert": "PGSSLCERT",
                   "sslkey": "PGSSLKEY", "sslcrl": "PGSSLCRL", "connect_timeout": "PGCONNECT_TIMEOUT"}
_DEBIAN_ROOT = Path("/usr/lib/postgresql")


class PostgresMissing(RuntimeError):
    """PostgreSQL's programs are not installed (Debian: the ``postgresql`` package; deploy/bootstrap.sh)."""


def shown_url(url: str | URL) -> str:
    """The URL as it may be logged or shown: the password replaced by ``***``."""
    try:
        return make_url(url).render_as_string(hide_password=True)
    except Exception:  # not a URL at all (a SQLite path): nothing secret in it
        return str(url)


def is_postgres(url: str | URL) -> bool:
    """True for a PostgreSQL URL (False for any other URL and for a SQLite path)."""
    return (isinstance(url, URL) or "://" in str(url)) and make_url(url).get_backend_name() == "postgresql"


def bin_dir() -> Path:
    """The folder of the newest installed PostgreSQL's server programs (``initdb``, ``pg_ctl``, ``pg_dump``):
    ``GAITCAP_PG_BIN`` when set, else Debian's ``/usr/lib/postgresql/<version>/bin``, else where ``pg_ctl``
    is on the PATH. PostgresMissing saying what to install otherwise."""
    if os.environ.get("GAITCAP_PG_BIN"):
        return Path(os.environ["GAITCAP_PG_BIN"])
    versions = sorted((p for p in _DEBIAN_ROOT.glob("*/bin") if (p / "initdb").exists()),
                      key=lambda p: int(p.parent.name) if p.parent.name.isdigit() else 0)
    if versions:
        return versions[-1]
    found = shutil.which("pg_ctl")
    if found:
        return Path(found).parent
    raise PostgresMissing("PostgreSQL's programs (initdb, pg_ctl, pg_dump) are not installed: install Debian's "
                          "postgresql package (deploy/bootstrap.sh does) or set GAITCAP_PG_BIN to their folder")


def program(name: str) -> str:
    path = bin_dir() / name
    if not path.exists():
        raise PostgresMissing(f"{name} not found in {path.parent} (Debian: the postgresql package)")
    return str(path)


def _passfile_line(url: URL) -> str:
    def esc(value) -> str:
        return str(value).replace("\\", "\\\\").replace(":", "\\:")

    return ":".join(esc(v) for v in (url.host or "localhost", url.port or 5432, url.database or "*",
                                      url.username or "*", url.password)) + "\n"


@contextlib.contextmanager
def passfile_for(url: str | URL) -> Iterator[Path | None]:
    """A passfile (0600, in a private temporary folder, removed afterwards) holding the URL's password, or
    None when the URL has none (the program then reads the user's own passfile)."""
    url = make_url(url)
    if url.password is None:
        yield None
        return
    with tempfile.TemporaryDirectory(prefix="gaitcap-pgpass-") as folder:
        path = Path(folder) / "pgpass"
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        with os.fdopen(fd, "w") as f:
            f.write(_passfile_line(url))
        yield path


@contextlib.contextmanager
def libpq_environment(url: str | URL, base: dict[str, str] | None = None) -> Iterator[dict[str, str]]:
    """The environment for a PostgreSQL program working on ``url``'s database: ``base`` (default: this
    process's) with PGHOST, PGPORT, PGUSER, PGDATABASE, the TLS settings of the URL's query (sslmode,
    sslrootcert, ...) and, when the URL carries a password, PGPASSFILE naming a passfile made for it."""
    url = make_url(url)
    env = dict(os.environ if base is None else base)
    env.pop("PGPASSWORD", None)  # never a password in the environment either
    for name, value in (("PGHOST", url.host), ("PGPORT", url.port), ("PGUSER", url.username),
                        ("PGDATABASE", url.database)):
        if value:
            env[name] = str(value)
    for key, name in QUERY_VARIABLES.items():
        if key in url.query:
            value = url.query[key]
            env[name] = value if isinstance(value, str) else value[-1]
    with passfile_for(url) as passfile:
        if passfile is not None:
            env["PGPASSFILE"] = str(passfile)
        yield env
