"""Identifier rules: ids are short, safe in file paths and URLs (no path traversal, no spaces)."""

from __future__ import annotations

import re
import secrets
import time

ID_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$"
"""A safe id: 1-64 letters, digits, ``_ . -``, starting with a letter or digit (``..`` is refused too)."""
_ID = re.compile(ID_PATTERN)


def validate_id(value: str, *, field: str) -> str:
    """Return ``value`` if it is a safe id (letters, digits, ``_ . -``, 1-64 chars, no ``..``).

    Raises ValueError naming ``field`` otherwise.
    """
    if not isinstance(value, str) or not _ID.match(value) or ".." in value:
        raise ValueError(
            f"{field}: {value!r} is not a valid id (1-64 letters, digits, '_', '.', '-'; "
            "must start with a letter or digit)"
        )
    return value


def new_trial_id(now_s: float | None = None) -> str:
    """A sortable, unique trial id such as ``T20261122-004512-3fa9c1``."""
    stamp = time.strftime("%Y%m%d-%H%M%S", time.gmtime(time.time() if now_s is None else now_s))
    return f"T{stamp}-{secrets.token_hex(3)}"
