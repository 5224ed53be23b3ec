"""API settings from arguments or the environment.

Environment: ``GAITCAP_DATA_DIR`` (trial files; accounts in ``accounts.json``, the audit trail in
``audit.log`` there), ``GAITCAP_CATALOG`` (SQLite path or SQLAlchemy URL), ``GAITCAP_HOST`` (default
127.0.0.1), ``GAITCAP_PORT`` (8000), ``GAITCAP_TLS_CERT`` / ``GAITCAP_TLS_KEY`` (PEM files: HTTPS),
``GAITCAP_TOKENS`` (``user:token,...``: API tokens for scripts, each acting as that user's account),
``GAITCAP_AUDIT_SYSLOG`` (``host:port`` or a socket path such as ``/dev/log``), ``GAITCAP_MIN_FREE_MB``
(2048: less free space on the data disk refuses Start), ``GAITCAP_ROOM`` (the capture
room this API runs: its trials, cameras and Start/Stop; '' the default room of a one-room clinic). The bus (``GAITCAP_BUS``)
is opened by ``gaitcap serve``, not here.
"""

from __future__ import annotations

import ipaddress
import os
import secrets
from dataclasses import dataclass, field
from pathlib import Path

from gaitcap.api.subject_ids import DEFAULT_PATTERN


def parse_tokens(text: str) -> dict[str, str]:
    """``"alice:tok1,bob:tok2"`` -> {token: user}. Raises ValueError naming a bad entry (never the token)."""
    tokens = {}
    for item in filter(None, (p.strip() for p in text.split(","))):
        user, sep, token = item.partition(":")
        if not sep or not user or len(token) < 16:
            raise ValueError(f"GAITCAP_TOKENS: entry for user {user or '?'!r} must be user:token with >= 16 "
                             "token characters")
        tokens[token] = user
    return tokens


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


@dataclass(frozen=True)
class Settings:
    """tokens: API token -> user name (the user's account gives the roles); tls_cert / tls_key: PEM files
    (HTTPS, HSTS, Secure cookies); plain_http_beyond_loopback: listen beyond loopback WITHOUT TLS
    (only behind a TLS reverse proxy on the same host); session_idle_s / session_max_s: automatic
    log-off after this long idle / after sign-in (s); max_body_bytes: larger request bodies are refused."""

    catalog_url: str
    data_dir: Path
    tokens: dict[str, str] = field(default_factory=dict)
    host: str = "127.0.0.1"
    port: int = 8000
    status_period_s: float = 0.5
    tls_cert: Path | None = None
    tls_key: Path | None = None
    plain_http_beyond_loopback: bool = False
    accounts_path: Path | None = None
    audit_path: Path | None = None
    audit_syslog: str | None = None
    session_idle_s: float = 15 * 60
    session_max_s: float = 10 * 3600
    max_body_bytes: int = 2 * 2**20
    login_failures: int = 5  # per user name and per client address ...
    login_window_s: float = 300.0  # ... within this window, then 429 until it has passed
    expensive_per_minute: int = 120
    backup_interval_s: float = 6 * 3600  # SQLite catalog backups (0: none) into DATA_DIR/backups ...
    backup_keep: int = 28  # ... the newest this many kept
    subject_id_pattern: str = DEFAULT_PATTERN  # a patient id must match it (and look like no name or date)
    min_free_mb: float = 2048.0  # the data disk with less free space (MB) than this: /health says so, Start refused
    board: dict | None = None  # the clinic's calibration board (a board file's [board] fields; None: the default)
    room: str = ""  # the capture room this API runs ('' the default room; gaitcap.services.catalog.rooms)

    def __post_init__(self) -> None:
        from gaitcap.services.catalog.rooms import check_room

        check_room(self.room)
        for token in self.tokens:
            if len(token) < 16:
                raise ValueError("tokens: every API token needs at least 16 characters")
        if (self.tls_cert is None) != (self.tls_key is None):
            raise ValueError("tls: give both the certificate and the private key")
        for f in (self.tls_cert, self.tls_key):
            if f is not None and not Path(f).is_file():
                raise ValueError(f"tls: {f} does not exist")
        if not is_loopback(self.host) and not self.tls_enabled and not self.plain_http_beyond_loopback:
            raise ValueError(f"host {self.host}: refusing to serve beyond loopback without TLS (give --tls-cert/"
                             "--tls-key or --self-signed; behind a TLS reverse proxy: --plain-http-beyond-loopback)")
        if self.accounts_path is None:
            object.__setattr__(self, "accounts_path", Path(self.data_dir) / "accounts.json")
        if self.audit_path is None:
            object.__setattr__(self, "audit_path", Path(self.data_dir) / "audit.log")

    @property
    def tls_enabled(self) -> bool:
        return self.tls_cert is not None

    @property
    def scheme(self) -> str:
        return "https" if self.tls_enabled else "http"

    @classmethod
    def from_env(cls, env: dict | None = None, **overrides) -> Settings:
        env = dict(os.environ if env is None else env)
        data_dir = Path(env.get("GAITCAP_DATA_DIR", "runs/clinic"))
        values = dict(
            tokens=parse_tokens(env.get("GAITCAP_TOKENS", "")),
            catalog_url=env.get("GAITCAP_CATALOG", str(data_dir / "catalog.sqlite")),
            data_dir=data_dir,
            host=env.get("GAITCAP_HOST", "127.0.0.1"),
            port=int(env.get("GAITCAP_PORT", "8000")),
            tls_cert=Path(env["GAITCAP_TLS_CERT"]) if env.get("GAITCAP_TLS_CERT") else None,
            tls_key=Path(env["GAITCAP_TLS_KEY"]) if env.get("GAITCAP_TLS_KEY") else None,
            audit_syslog=env.get("GAITCAP_AUDIT_SYSLOG") or None,
            subject_id_pattern=env.get("GAITCAP_SUBJECT_ID_PATTERN") or DEFAULT_PATTERN,
            min_free_mb=float(env.get("GAITCAP_MIN_FREE_MB") or 2048.0),
            room=env.get("GAITCAP_ROOM", ""),
        )
        values.update(overrides)
        return cls(**values)


def new_token() -> str:
    return secrets.token_urlsafe(24)
