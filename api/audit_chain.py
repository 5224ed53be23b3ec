"""The append-only audit trail: JSON lines, each with the SHA-256 of the previous line (a hash chain),
so an edited, removed or reordered line is detected by :func:`verify`. Optionally also sent to syslog.

Each line: ``{"at": unix s, "actor": user, "action", "target", "detail", "ip", "prev": hex, "hash": hex}``
where ``hash = sha256(prev + canonical JSON of the other fields)``. The actor is always the signed-in
user (or ``-`` for a failed sign-in, with the name tried in ``detail``), never a name the client sent.
"""

from __future__ import annotations

import hashlib
import json
import logging
import logging.handlers
import os
import threading
import time
from pathlib import Path

GENESIS = "0" * 64
log = logging.getLogger(__name__)


def _digest(prev: str, fields: dict) -> str:
    return hashlib.sha256((prev + json.dumps(fields, sort_keys=True, separators=(",", ":"))).encode()).hexdigest()


class AuditChain:
    def __init__(self, path: str | os.PathLike, *, syslog_address: str | None = None) -> None:
        self.path = Path(path)
        self._lock = threading.Lock()
        self._last = self._last_hash()
        self._syslog = None
        if syslog_address:
            host, _, port = syslog_address.partition(":")
            address = host if host.startswith("/") else (host, int(port or 514))
            self._syslog = logging.handlers.SysLogHandler(address=address)

    def _last_hash(self) -> str:
        if not self.path.exists():
            return GENESIS
        last = GENESIS
        with self.path.open() as f:
            for line in f:
                if line.strip():
                    last = json.loads(line)["hash"]
        return last

    def record(self, *, actor: str, action: str, target: str = "", detail: str = "", ip: str = "") -> None:
        fields = {"at": round(time.time(), 3), "actor": actor[:128], "action": action[:64], "target": target[:256],
                  "detail": detail[:500], "ip": ip[:64]}
        with self._lock:
            entry = dict(fields, prev=self._last, hash=_digest(self._last, fields))
            line = json.dumps(entry, separators=(",", ":"))
            self.path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o600)
            with os.fdopen(fd, "a") as f:
                f.write(line + "\n")
            self._last = entry["hash"]
        if self._syslog is not None:  # the same line, so the copy verifies like the file
            self._syslog.emit(logging.LogRecord("gaitcap.audit", logging.INFO, "", 0, "gaitcap-audit %s",
                                                (line,), None))


def verify(path: str | os.PathLike) -> tuple[int, str | None]:
    """(entries checked, None) when the chain is intact, else (line number, what is wrong)."""
    prev, n = GENESIS, 0
    with Path(path).open() as f:
        for n, line in enumerate(f, start=1):
            entry = json.loads(line)
            fields = {k: entry[k] for k in ("at", "actor", "action", "target", "detail", "ip")}
            if entry["prev"] != prev:
                return n, f"line {n}: previous hash does not match line {n - 1} (a line was removed or moved)"
            if _digest(prev, fields) != entry["hash"]:
                return n, f"line {n}: content does not match its hash (edited)"
            prev = entry["hash"]
    return n, None
