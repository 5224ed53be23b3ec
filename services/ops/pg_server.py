"""A PostgreSQL server of its own in a folder: the throwaway catalog server of the tests and benchmarks.

:class:`LocalPostgres` makes a cluster with ``initdb`` in a new temporary folder, starts it with ``pg_ctl`` on
a free loopback port (TCP on 127.0.0.1, and on ``also_listen``'s addresses; its socket in the folder), and stops
and removes it. As root,
the server runs as the ``postgres`` account Debian's package makes (PostgreSQL refuses to run as root), in a
folder owned by it. Passwords are checked with SCRAM-SHA-256; TLS is on (a certificate for 127.0.0.1 signed
by a CA of its own, :attr:`LocalPostgres.ca_file`) and each client chooses it with ``sslmode``.

Two roles: the superuser ``postgres`` (creating databases) and ``gaitcap``, a plain login role that owns each
catalog database. Both passwords are random and exist only in the password file :attr:`passfile` (0600,
owned by the user running this); every URL this hands out has none, so none appears in a log or in a
process listing: clients read it through ``PGPASSFILE`` (:meth:`environment`). The cluster is tuned for
speed, not durability (no fsync): it is thrown away.
"""

from __future__ import annotations

import contextlib
import logging
import os
import pwd
import secrets
import shutil
import socket
import subprocess
import tempfile
from pathlib import Path

from gaitcap.services.catalog.pg_tools import program
from sqlalchemy.engine import URL

log = logging.getLogger(__name__)
APP_ROLE, ADMIN_ROLE = "gaitcap", "postgres"
_SETTINGS = {  # throwaway: speed over durability
    "listen_addresses": "'127.0.0.1'", "fsync": "off", "synchronous_commit": "off", "full_page_writes": "off",
    "max_connections": "200", "ssl": "on", "ssl_cert_file": "'server.pem'", "ssl_key_file": "'server.key'",
    "password_encryption": "'scram-sha-256'", "log_min_messages": "warning",
}


def free_port() -> int:
    """A TCP port free on 127.0.0.1 now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _server_account() -> pwd.struct_passwd | None:
    """Who runs the server: None (this user) unless this is root, then Debian's ``postgres`` account."""
    if os.geteuid() != 0:
        return None
    try:
        return pwd.getpwnam("postgres")
    except KeyError as exc:
        raise RuntimeError("PostgreSQL refuses to run as root and there is no 'postgres' account to run it "
                           "(Debian's postgresql package makes it)") from exc


class LocalPostgres:
    """``with LocalPostgres() as pg: url = pg.create_database("cat1")`` (see the module docstring)."""

    def __init__(self, *, port: int | None = None, also_listen: tuple[str, ...] = ()) -> None:
        self.port = port or free_port()
        self.also_listen = tuple(also_listen)  # more IPv4 addresses of this host (the rooms' links): see start
        self.account = _server_account()
        self.client_dir = Path(tempfile.mkdtemp(prefix="gaitcap-pg-client-"))  # ours, 0700: passfile, CA
        self.root = Path(tempfile.mkdtemp(prefix="gaitcap-pg-"))  # the server's: data, socket, log
        self.data = self.root / "data"
        self.passfile = self.client_dir / "pgpass"
        self.ca_file = self.client_dir / "ca.pem"
        self._passwords = {APP_ROLE: secrets.token_urlsafe(24), ADMIN_ROLE: secrets.token_urlsafe(24)}
        self.started = False

    # -- running the server's programs as its account ---------------------------------------------------
    def _run(self, *argv: str, timeout_s: float = 60.0) -> None:
        as_user = {} if self.account is None else {"user": self.account.pw_uid, "group": self.account.pw_gid,
                                                   "extra_groups": []}
        done = subprocess.run(argv, cwd=self.root, capture_output=True, text=True, timeout=timeout_s,
                              env={"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "LC_ALL": "C.UTF-8"}, **as_user)
        if done.returncode != 0:
            raise RuntimeError(f"{Path(argv[0]).name} failed ({done.returncode}): {done.stderr.strip()[-800:]}")

    def _give(self, path: Path, mode: int) -> None:
        path.chmod(mode)
        if self.account is not None:
            os.chown(path, self.account.pw_uid, self.account.pw_gid)

    def _write_private(self, path: Path, text: str | bytes, *, server: bool) -> None:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "wb") as f:
            f.write(text.encode() if isinstance(text, str) else text)
        if server:
            self._give(path, 0o600)

    def start(self) -> LocalPostgres:
        """initdb (SCRAM for every connection, the admin's password from a file that is removed at once),
        TLS files, the settings, pg_ctl start, then the app role."""
        self._give(self.root, 0o700)
        pwfile = self.root / "pw"
        self._write_private(pwfile, self._passwords[ADMIN_ROLE] + "\n", server=True)
        try:
            self._run(program("initdb"), "-D", str(self.data), "-U", ADMIN_ROLE, "--pwfile", str(pwfile),
                      "--auth-local=scram-sha-256", "--auth-host=scram-sha-256", "-E", "UTF8", "--locale=C.UTF-8",
                      "--no-sync")
        finally:
            pwfile.unlink(missing_ok=True)
        self._tls_files()
        settings = {**_SETTINGS, "port": str(self.port), "unix_socket_directories": f"'{self.root}'"}
        if self.also_listen:  # clients on those links' subnets sign in as on loopback (SCRAM)
            settings["listen_addresses"] = "'" + ",".join(("127.0.0.1", *self.also_listen)) + "'"
            with open(self.data / "pg_hba.conf", "a") as f:
                f.write("host all all samenet scram-sha-256\n")
        with open(self.data / "postgresql.conf", "a") as f:
            f.write("".join(f"{k} = {v}\n" for k, v in settings.items()))
        self._run(program("pg_ctl"), "-D", str(self.data), "-l", str(self.root / "server.log"), "-w", "-t", "60",
                  "start")
        self.started = True
        self._write_private(self.passfile, "".join(f"{host}:{self.port}:*:{role}:{pw}\n"
                                                   for host in ("127.0.0.1", *self.also_listen)
                                                   for role, pw in self._passwords.items()), server=False)
        from psycopg import sql

        with self.admin() as conn:  # a utility statement takes no bound parameters: a quoted literal
            conn.execute(sql.SQL("CREATE ROLE {} LOGIN PASSWORD {}").format(
                sql.Identifier(APP_ROLE), sql.Literal(self._passwords[APP_ROLE])))
        log.info("throwaway PostgreSQL on 127.0.0.1:%d (cluster %s)", self.port, self.root)
        return self

    def _tls_files(self) -> None:
        from gaitcap.services.bus.certs import web_certificate

        pem, key = web_certificate("127.0.0.1", self.client_dir / "tls")
        shutil.copyfile(self.client_dir / "tls" / "ca.pem", self.ca_file)
        self._write_private(self.data / "server.pem", pem.read_bytes(), server=True)
        self._write_private(self.data / "server.key", key.read_bytes(), server=True)

    @contextlib.contextmanager
    def admin(self):
        """A psycopg connection as the superuser (autocommit), its password read from the passfile."""
        import psycopg

        with psycopg.connect(host="127.0.0.1", port=self.port, user=ADMIN_ROLE, dbname="postgres",
                             passfile=str(self.passfile), autocommit=True) as conn:
            yield conn

    def url(self, database: str, *, role: str = APP_ROLE, host: str = "127.0.0.1", **query: str) -> str:
        """The SQLAlchemy URL of ``database`` (no password: it is in :attr:`passfile`) at ``host`` (127.0.0.1 or
        one of ``also_listen``); ``query``: libpq options such as ``sslmode="verify-full", sslrootcert=...``."""
        return URL.create("postgresql+psycopg", username=role, host=host, port=self.port,
                          database=database, query=query).render_as_string(hide_password=False)

    def create_database(self, name: str, **query: str) -> str:
        """A new empty database owned by the app role: its URL."""
        with self.admin() as conn:
            conn.execute(f'CREATE DATABASE "{name}" OWNER {APP_ROLE}')
        return self.url(name, **query)

    def password(self, role: str = APP_ROLE) -> str:
        """The role's password (for a test that checks where a password must not show up)."""
        return self._passwords[role]

    def environment(self) -> dict[str, str]:
        """What a client process needs in its environment to sign in: ``PGPASSFILE``."""
        return {"PGPASSFILE": str(self.passfile)}

    def pause(self) -> None:
        """Stop the server, keeping its cluster (a database host gone for a while; :meth:`resume`)."""
        self._run(program("pg_ctl"), "-D", str(self.data), "-m", "fast", "-w", "stop")

    def resume(self) -> None:
        """Start the paused server again on the same port."""
        self._run(program("pg_ctl"), "-D", str(self.data), "-l", str(self.root / "server.log"), "-w", "-t", "60",
                  "start")

    def stop(self) -> None:
        """Stop the server (fast shutdown) and remove its folders."""
        if self.started:
            try:
                self._run(program("pg_ctl"), "-D", str(self.data), "-m", "fast", "-w", "stop")
            except (RuntimeError, subprocess.TimeoutExpired):
                log.exception("throwaway PostgreSQL: stop failed")
            self.started = False
        shutil.rmtree(self.root, ignore_errors=True)
        shutil.rmtree(self.client_dir, ignore_errors=True)

    def __enter__(self) -> LocalPostgres:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
