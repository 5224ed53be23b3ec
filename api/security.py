"""Everything the web service needs to be safe to expose, installed on the app in one call:
accounts, sessions, the audit trail, login throttling, the request guard (:mod:`gaitcap.api.http_guard`),
the sign-in routes and the API docs served from the installed package (no CDN, no inline script).
"""

from __future__ import annotations

import os
from pathlib import Path

from fastapi import FastAPI
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles
from gaitcap.api import routes_auth, routes_retention
from gaitcap.api.audit_chain import AuditChain
from gaitcap.api.http_guard import HttpGuard
from gaitcap.api.sessions import RateLimiter, SessionStore
from gaitcap.api.settings import Settings
from gaitcap.services.access.accounts import AccountStore

DOCS_HTML = """<!doctype html><html><head><meta charset="utf-8"><title>gaitcap API</title>
<link rel="stylesheet" href="/static-docs/swagger-ui.css"></head>
<body><div id="swagger-ui"></div><script src="/static-docs/swagger-ui-bundle.js"></script>
<script src="/static/docs-init.js"></script></body></html>"""


def install_security(app: FastAPI, settings: Settings) -> None:
    os.umask(0o077)  # every file the service writes: 0600, folders 0700
    Path(settings.data_dir).mkdir(parents=True, exist_ok=True)
    app.state.accounts = AccountStore(settings.accounts_path)
    app.state.sessions = SessionStore(idle_s=settings.session_idle_s, max_s=settings.session_max_s)
    app.state.audit_chain = AuditChain(settings.audit_path, syslog_address=settings.audit_syslog)
    app.state.login_limiters = {  # failed sign-ins per user name, and (4x as many) per client address
        "user": RateLimiter(settings.login_failures, settings.login_window_s),
        "ip": RateLimiter(4 * settings.login_failures, settings.login_window_s)}
    app.include_router(routes_auth.router)
    app.include_router(routes_retention.router)
    app.add_middleware(HttpGuard, max_body_bytes=settings.max_body_bytes, tls=settings.tls_enabled,
                       expensive_limiter=RateLimiter(settings.expensive_per_minute, 60.0))
    _docs(app)


def start_backups(settings: Settings):
    """The catalog's backup schedule (None when off or the catalog is not SQLite); stop it at shutdown."""
    from gaitcap.api.backups import BackupSchedule, sqlite_path

    src = sqlite_path(settings.catalog_url)
    if src is None or settings.backup_interval_s <= 0:
        return None
    return BackupSchedule(src, Path(settings.data_dir) / "backups", interval_s=settings.backup_interval_s,
                          keep=settings.backup_keep).start()


def _docs(app: FastAPI) -> None:
    try:
        import fastapi_offline
    except ImportError:  # the docs page needs the package's Swagger UI files; /openapi.json still works
        return
    app.mount("/static-docs", StaticFiles(directory=Path(fastapi_offline.__file__).parent / "static"),
              name="static-docs")

    @app.get("/docs", include_in_schema=False)
    def docs() -> HTMLResponse:
        return HTMLResponse(DOCS_HTML)
