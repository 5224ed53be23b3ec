"""Token authentication: ``Authorization: Bearer <token>`` or ``?token=`` (for links, images, WebSockets).

The caller's user name (from the token) and an optional ``X-Gaitcap-User`` display name go into the
audit log as the actor.
"""

from __future__ import annotations

import re
import secrets

from fastapi import HTTPException, Request, WebSocket

_NAME = re.compile(r"[^A-Za-z0-9_.@ -]")


def _lookup(tokens: dict[str, str], given: str | None) -> str | None:
    if not given:
        return None
    for token, user in tokens.items():
        if secrets.compare_digest(token.encode(), given.encode()):
            return user
    return None


def _given_token(headers, query) -> str | None:
    auth = headers.get("authorization", "")
    if auth.lower().startswith("bearer "):
        return auth[7:].strip()
    return query.get("token")


def actor_of(user: str, headers) -> str:
    shown = _NAME.sub("", headers.get("x-gaitcap-user", ""))[:40].strip()
    return f"{user}:{shown}" if shown else user


def require_user(request: Request) -> str:
    """FastAPI dependency: the actor name, or 401."""
    user = _lookup(request.app.state.settings.tokens, _given_token(request.headers, request.query_params))
    if user is None:
        raise HTTPException(status_code=401, detail="token: missing or wrong API token",
                            headers={"WWW-Authenticate": "Bearer"})
    return actor_of(user, request.headers)


def websocket_user(ws: WebSocket) -> str | None:
    user = _lookup(ws.app.state.settings.tokens, _given_token(ws.headers, ws.query_params))
    return None if user is None else actor_of(user, ws.headers)
