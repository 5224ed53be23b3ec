"""API settings from arguments or the environment.

Environment: ``GAITCAP_TOKEN`` (one token, user ``clinic``) or ``GAITCAP_TOKENS`` (``user:token,...``),
``GAITCAP_CATALOG`` (SQLite path or SQLAlchemy URL), ``GAITCAP_DATA_DIR``, ``GAITCAP_HOST`` (default
127.0.0.1), ``GAITCAP_PORT`` (8000). The bus (``GAITCAP_BUS``) is opened by ``gaitcap serve``, not here.
"""

from __future__ import annotations

import os
import secrets
from dataclasses import dataclass, field
from pathlib import Path

from gaitcap.services.catalog.paths import DEFAULT_DATA_DIR, catalog_url


def parse_tokens(text: str) -> dict[str, str]:
    """``"alice:tok1,bob:tok2"`` -> {token: user}. Raises ValueError naming a bad entry."""
    tokens = {}
    for item in filter(None, (p.strip() for p in text.split(","))):
        user, sep, token = item.partition(":")
        if not sep or not user or len(token) < 8:
            raise ValueError(f"GAITCAP_TOKENS: entry {user or item!r} must be user:token with >= 8 token chars")
        tokens[token] = user
    return tokens


@dataclass(frozen=True)
class Settings:
    """tokens: token -> user name (the name goes into the audit log)."""

    tokens: dict[str, str]
    catalog_url: str
    data_dir: Path
    host: str = "127.0.0.1"
    port: int = 8000
    status_period_s: float = 0.5
    extra: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.tokens:
            raise ValueError("tokens: at least one API token is required")
        for token in self.tokens:
            if len(token) < 8:
                raise ValueError("tokens: every token needs at least 8 characters")

    @classmethod
    def from_env(cls, env: dict | None = None, **overrides) -> Settings:
        env = dict(os.environ if env is None else env)
        tokens = parse_tokens(env.get("GAITCAP_TOKENS", ""))
        if env.get("GAITCAP_TOKEN"):
            tokens[env["GAITCAP_TOKEN"]] = "clinic"
        data_dir = Path(env.get("GAITCAP_DATA_DIR", DEFAULT_DATA_DIR))
        values = dict(
            tokens=tokens,
            catalog_url=catalog_url(data_dir, env.get("GAITCAP_CATALOG")),
            data_dir=data_dir,
            host=env.get("GAITCAP_HOST", "127.0.0.1"),
            port=int(env.get("GAITCAP_PORT", "8000")),
        )
        values.update(overrides)
        return cls(**values)


def new_token() -> str:
    return secrets.token_urlsafe(18)
