"""Signed-in sessions (server side, random ids in an HttpOnly cookie), login throttling, rate limits.

A session ends after ``idle_s`` without a request (automatic log-off) or ``max_s`` after sign-in,
whichever comes first, and on sign-out. Sessions live in the web service's memory: a restart signs
everyone out.
"""

from __future__ import annotations

import secrets
import threading
import time
from collections import deque
from dataclasses import dataclass

COOKIE = "gaitcap_session"


@dataclass
class Session:
    user: str
    roles: tuple[str, ...]
    permissions: frozenset[str]
    created_s: float
    seen_s: float


class SessionStore:
    def __init__(self, *, idle_s: float, max_s: float) -> None:
        self.idle_s, self.max_s = idle_s, max_s
        self._sessions: dict[str, Session] = {}
        self._lock = threading.Lock()

    def create(self, user: str, roles: tuple[str, ...], permissions: frozenset[str]) -> str:
        sid = secrets.token_urlsafe(32)
        now = time.monotonic()
        with self._lock:
            self._sessions[sid] = Session(user, roles, permissions, now, now)
        return sid

    def get(self, sid: str | None) -> Session | None:
        """The live session of ``sid`` (its idle timer restarts), else None."""
        if not sid:
            return None
        now = time.monotonic()
        with self._lock:
            s = self._sessions.get(sid)
            if s is None:
                return None
            if now - s.seen_s > self.idle_s or now - s.created_s > self.max_s:
                del self._sessions[sid]
                return None
            s.seen_s = now
            return s

    def end(self, sid: str | None) -> None:
        with self._lock:
            self._sessions.pop(sid or "", None)

    def end_user(self, user: str) -> None:
        with self._lock:
            for sid in [k for k, s in self._sessions.items() if s.user == user]:
                del self._sessions[sid]


class RateLimiter:
    """At most ``limit`` events per ``window_s`` per key (sliding window)."""

    def __init__(self, limit: int, window_s: float) -> None:
        self.limit, self.window_s = limit, window_s
        self._events: dict[str, deque] = {}
        self._lock = threading.Lock()

    def _recent(self, key: str, now: float) -> deque:
        q = self._events.setdefault(key, deque())
        while q and now - q[0] > self.window_s:
            q.popleft()
        return q

    def blocked(self, key: str) -> bool:
        with self._lock:
            return len(self._recent(key, time.monotonic())) >= self.limit

    def hit(self, key: str) -> bool:
        """Count one event; True when the key is over its limit (the event is then not counted)."""
        now = time.monotonic()
        with self._lock:
            q = self._recent(key, now)
            if len(q) >= self.limit:
                return True
            q.append(now)
            return False

    def clear(self, key: str) -> None:
        with self._lock:
            self._events.pop(key, None)
