"""User accounts of the web service: names, roles, argon2id password hashes, in one 0600 JSON file.

Roles and what they may do (a user may hold several roles):

===========  ==================================================================
role         permissions
===========  ==================================================================
clinician    ``record`` (start/stop trials, choose the patient), ``read``, ``live``
engineer     ``calibrate`` (board recordings, calibrations), ``read``, ``live``
researcher   ``read``, ``export`` (recordings, trajectories, steps, Rerun files)
admin        ``users`` (accounts), ``audit`` (the audit log), ``retention`` (void trials)
===========  ==================================================================

Manage accounts with ``gaitcap user add|list|remove`` (the file is ``<data dir>/accounts.json``).
"""

from __future__ import annotations

import json
import os
import re
import threading
from dataclasses import asdict, dataclass
from pathlib import Path

from argon2 import PasswordHasher
from argon2.exceptions import InvalidHashError, VerificationError, VerifyMismatchError

ROLES: dict[str, frozenset[str]] = {
    "clinician": frozenset({"record", "read", "live"}),
    "engineer": frozenset({"calibrate", "read", "live"}),
    "researcher": frozenset({"read", "export"}),
    "admin": frozenset({"users", "audit", "retention"}),
}
PERMISSIONS = frozenset().union(*ROLES.values())
MIN_PASSWORD = 12
_USER = re.compile(r"^[a-z0-9][a-z0-9_.@-]{0,63}$")
_HASHER = PasswordHasher()  # argon2id, the library's current defaults
_DUMMY_HASH = _HASHER.hash("an unknown user still costs one hash")


def check_user_name(name: str) -> str:
    if not isinstance(name, str) or not _USER.match(name):
        raise ValueError(f"user: {str(name)[:40]!r} must be 1-64 lower-case letters, digits, '_ . @ -'")
    return name


def check_roles(roles) -> tuple[str, ...]:
    roles = tuple(sorted(set(roles)))
    unknown = [r for r in roles if r not in ROLES]
    if not roles or unknown:
        raise ValueError(f"roles: {unknown or 'none given'}; choose from {sorted(ROLES)}")
    return roles


@dataclass(frozen=True)
class Account:
    name: str
    roles: tuple[str, ...]
    password_hash: str

    @property
    def permissions(self) -> frozenset[str]:
        return frozenset().union(*(ROLES[r] for r in self.roles))


class AccountStore:
    """Accounts in a JSON file (written atomically, mode 0600); safe to share between threads."""

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = Path(path)
        self._lock = threading.Lock()

    def _load(self) -> dict[str, Account]:
        if not self.path.exists():
            return {}
        data = json.loads(self.path.read_text())
        return {a["name"]: Account(a["name"], tuple(a["roles"]), a["password_hash"]) for a in data["accounts"]}

    def _save(self, accounts: dict[str, Account]) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        tmp = self.path.with_name(self.path.name + ".tmp")
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "w") as f:
            json.dump({"accounts": [asdict(a) for a in accounts.values()]}, f, indent=1)
        os.replace(tmp, self.path)

    def list(self) -> list[Account]:
        with self._lock:
            return sorted(self._load().values(), key=lambda a: a.name)

    def get(self, name: str) -> Account | None:
        with self._lock:
            return self._load().get(name)

    def set(self, name: str, *, password: str, roles) -> Account:
        """Create or replace an account; ValueError naming the bad field."""
        check_user_name(name)
        if not isinstance(password, str) or len(password) < MIN_PASSWORD:
            raise ValueError(f"password: at least {MIN_PASSWORD} characters")
        account = Account(name, check_roles(roles), _HASHER.hash(password))
        with self._lock:
            accounts = self._load()
            accounts[name] = account
            self._save(accounts)
        return account

    def remove(self, name: str) -> bool:
        with self._lock:
            accounts = self._load()
            if accounts.pop(name, None) is None:
                return False
            self._save(accounts)
            return True

    def verify(self, name: str, password: str) -> Account | None:
        """The account when ``password`` is right, else None (same cost for unknown users)."""
        account = self.get(name) if isinstance(name, str) and _USER.match(name) else None
        try:
            _HASHER.verify(account.password_hash if account else _DUMMY_HASH, password)
        except (VerifyMismatchError, VerificationError, InvalidHashError):
            return None
        return account
