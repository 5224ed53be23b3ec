"""Who is calling and what they may do: session cookies (the page) or per-user API tokens (scripts).

- The page signs in with ``POST /login`` (user + password, :mod:`gaitcap.api.routes_auth`) and then
  carries the ``gaitcap_session`` cookie (HttpOnly, SameSite=Strict, Secure on HTTPS) on every request,
  download and WebSocket. Nothing secret ever goes into a URL.
- Scripts may send ``Authorization: Bearer <token>`` with a token of ``GAITCAP_TOKENS``
  (``user:token,...``); the token acts as that user's account (its roles).

Every route needs a permission (:data:`ROUTE_PERMISSIONS`, by method and path template); a route
missing from the table is refused to everyone (and a test checks the table covers the OpenAPI schema).
Every authorised request is written to the audit trail as the signed-in user.
"""

from __future__ import annotations

import secrets
from dataclasses import dataclass
from urllib.parse import urlsplit

from fastapi import HTTPException, Request, WebSocket
from gaitcap.api.sessions import COOKIE

READ, LIVE, RECORD, CALIBRATE, EXPORT = "read", "live", "record", "calibrate", "export"
USERS, AUDIT, RETENTION = "users", "audit", "retention"

#: (method, path template) -> the permissions any of which lets a user call it.
ROUTE_PERMISSIONS: dict[tuple[str, str], frozenset[str]] = {
    ("GET", "/trials"): frozenset({READ}),
    ("GET", "/trials/{trial_id}"): frozenset({READ}),
    ("GET", "/trials/{trial_id}/gait"): frozenset({READ}),
    ("GET", "/trials/{trial_id}/people"): frozenset({READ}),
    ("GET", "/trials/{trial_id}/report.png"): frozenset({READ}),
    ("GET", "/trials/{trial_id}/still/{camera}.jpg"): frozenset({READ}),
    ("GET", "/trials/{trial_id}/steps"): frozenset({READ}),
    ("GET", "/trials/{trial_id}/recording"): frozenset({EXPORT}),
    ("GET", "/trials/{trial_id}/rerun.rrd"): frozenset({EXPORT}),
    ("GET", "/trials/{trial_id}/results.mcap"): frozenset({EXPORT}),
    ("GET", "/trials/{trial_id}/trajectory"): frozenset({EXPORT}),
    ("GET", "/trials/{trial_id}/kinematics"): frozenset({READ}),
    ("GET", "/trials/{trial_id}/validation"): frozenset({READ}),
    ("GET", "/trials/{trial_id}/validation/{name}"): frozenset({READ}),
    ("POST", "/trials"): frozenset({RECORD}),
    ("POST", "/trials/{trial_id}/stop"): frozenset({RECORD}),
    ("POST", "/trials/{trial_id}/patient"): frozenset({RECORD}),
    ("POST", "/trials/{trial_id}/void"): frozenset({RETENTION}),
    ("GET", "/trials/{trial_id}/report.pdf"): frozenset({READ}),
    ("GET", "/trials/{trial_id}/parameters"): frozenset({READ}),
    ("GET", "/trials/{trial_id}/figures"): frozenset({READ}),
    ("POST", "/trials/{trial_id}/correct"): frozenset({RECORD}),
    ("POST", "/trials/{trial_id}/mark-void"): frozenset({RECORD}),
    ("GET", "/patients"): frozenset({READ}),
    ("GET", "/patients/{subject_id}"): frozenset({READ}),
    ("PUT", "/patients/{subject_id}"): frozenset({RECORD}),
    ("GET", "/calibrations"): frozenset({READ, CALIBRATE}),
    ("GET", "/calibrations/latest"): frozenset({READ, CALIBRATE}),
    ("GET", "/rig-check/latest"): frozenset({READ, CALIBRATE}),
    ("GET", "/calibrations/{cal_id}/version"): frozenset({READ, CALIBRATE}),
    ("POST", "/calibrations/{cal_id}/apply"): frozenset({CALIBRATE}),
    ("GET", "/calibrations/{cal_id}"): frozenset({READ, CALIBRATE}),
    ("GET", "/calibrations/{cal_id}/toml"): frozenset({CALIBRATE, EXPORT}),
    ("POST", "/calibrations"): frozenset({CALIBRATE}),
    ("POST", "/calibrations/record/start"): frozenset({CALIBRATE}),
    ("POST", "/calibrations/record/stop"): frozenset({CALIBRATE}),
    ("GET", "/calibrations/record/coverage"): frozenset({CALIBRATE}),
    ("GET", "/cameras"): frozenset({LIVE}),
    ("GET", "/cameras/{name}/preview.jpg"): frozenset({LIVE}),
    ("GET", "/cameras/{name}/preview.mjpg"): frozenset({LIVE}),
    ("GET", "/status"): frozenset({READ, LIVE}),
    ("GET", "/rooms"): frozenset({READ, LIVE}),
    ("WS", "/ws/status"): frozenset({READ, LIVE}),
    ("WS", "/ws/preview"): frozenset({LIVE}),
    ("GET", "/audit"): frozenset({AUDIT}),
    ("GET", "/users"): frozenset({USERS}),
    ("POST", "/users"): frozenset({USERS}),
    ("DELETE", "/users/{name}"): frozenset({USERS}),
}
#: Routes open to anyone (the page's files, sign-in, liveness).
PUBLIC_PATHS = ("/", "/health", "/login", "/logout", "/me", "/docs", "/openapi.json", "/favicon.ico")
PUBLIC_PREFIXES = ("/static/", "/static-docs/")


@dataclass(frozen=True)
class Principal:
    user: str
    roles: tuple[str, ...]
    permissions: frozenset[str]
    via: str  # "session" | "token"


def _token_user(request, tokens: dict[str, str]) -> str | None:
    auth = request.headers.get("authorization", "")
    if not auth.lower().startswith("bearer "):
        return None
    given = auth[7:].strip().encode()
    for token, user in tokens.items():
        if secrets.compare_digest(token.encode(), given):
            return user
    return None


def principal_of(conn) -> Principal | None:
    """The caller of an HTTP request or WebSocket (session cookie, else Bearer token), or None."""
    state = conn.app.state
    session = state.sessions.get(conn.cookies.get(COOKIE))
    if session is not None:
        return Principal(session.user, session.roles, session.permissions, "session")
    user = _token_user(conn, state.settings.tokens)
    account = state.accounts.get(user) if user else None
    if account is None:
        return None
    return Principal(account.name, account.roles, account.permissions, "token")


def is_public(path: str) -> bool:
    return path in PUBLIC_PATHS or path.startswith(PUBLIC_PREFIXES)


def _allowed(principal: Principal, method: str, template: str) -> bool:
    needed = ROUTE_PERMISSIONS.get((method, template))
    return needed is not None and bool(needed & principal.permissions)


def client_ip(conn) -> str:
    return conn.client.host if conn.client else ""


def require_user(request: Request) -> str:
    """FastAPI dependency: the signed-in user's name (401 when not signed in, 403 without the role's
    permission for this route); the access goes to the audit trail."""
    principal = principal_of(request)
    if principal is None:
        raise HTTPException(status_code=401, detail="not signed in", headers={"WWW-Authenticate": "Bearer"})
    template = getattr(request.scope.get("route"), "path", request.url.path)
    if not _allowed(principal, request.method, template):
        request.app.state.audit_chain.record(actor=principal.user, action="denied",
                                             target=f"{request.method} {request.url.path}", ip=client_ip(request))
        raise HTTPException(status_code=403, detail=f"your roles {list(principal.roles)} do not allow this")
    request.app.state.audit_chain.record(actor=principal.user, action=request.method.lower(),
                                         target=request.url.path, detail=request.url.query[:200],
                                         ip=client_ip(request))
    return principal.user


def _origin_ok(ws: WebSocket) -> bool:
    """A browser's WebSocket must come from this site's own page (Origin host = Host)."""
    origin = ws.headers.get("origin")
    if origin is None:
        return True  # not a browser (browsers always send Origin)
    return urlsplit(origin).netloc == ws.headers.get("host", "")


def websocket_user(ws: WebSocket) -> str | None:
    """The signed-in user of a WebSocket with the route's permission and a same-site Origin, else None."""
    principal = principal_of(ws)
    template = getattr(ws.scope.get("route"), "path", ws.url.path)
    if principal is None or not _origin_ok(ws) or not _allowed(principal, "WS", template):
        return None
    ws.app.state.audit_chain.record(actor=principal.user, action="live", target=ws.url.path, ip=client_ip(ws))
    return principal.user
