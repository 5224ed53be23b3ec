"""The FastAPI application factory: ``create_app(settings, link)``.

``link`` connects the API to the live system (recorder, camera health, previews); without one the API
serves the catalog only. Binds 127.0.0.1 by default (see :mod:`gaitcap.api.server`).
"""

from __future__ import annotations

import contextlib
import logging
import socket
from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, JSONResponse
from fastapi.staticfiles import StaticFiles
from gaitcap.api import (
    routes_calibration_versions,
    routes_calibrations,
    routes_kinematics,
    routes_live,
    routes_patients,
    routes_people,
    routes_report,
    routes_results,
    routes_rig_check,
    routes_rooms,
    routes_trials,
    routes_validation,
)
from gaitcap.api.security import install_security, start_backups
from gaitcap.api.settings import Settings
from gaitcap.services import catalog as cat
from gaitcap.services.catalog.audit_queue import AuditQueue
from gaitcap.services.catalog.ids import ID_PATTERN
from gaitcap.services.live.guard import TrialGuard
from gaitcap.services.live.health import health_report
from gaitcap.services.live.pending_stops import PendingStops
from gaitcap.services.live.protocols import NoLink, NoScene
from gaitcap.services.live.room_report import RoomReporter
from sqlalchemy.exc import OperationalError

log = logging.getLogger(__name__)
ID_WORDS = "use letters, digits, '.', '_' or '-' (up to 64), starting with a letter or digit; no spaces"
STATIC = Path(__file__).parent / "static"


def _field_errors(exc: RequestValidationError) -> JSONResponse:
    """422 whose ``detail`` names the field(s): ``"subject_id: String should match pattern ..."``; the
    client's input is never echoed back (at most the first 10 errors, each message cut to 200 characters)."""
    parts = []
    for err in exc.errors()[:10]:
        loc = [str(p) for p in err.get("loc", ()) if p not in ("body", "query", "path")]
        msg = _pattern_words(err) if err.get("type") == "string_pattern_mismatch" else str(err.get("msg", "invalid"))[:200]
        parts.append(f"{'.'.join(loc)[:80] or 'body'}: {msg}")
    return JSONResponse(status_code=422, content={"detail": "; ".join(parts), "errors": jsonable(exc.errors()[:10])})


def _pattern_words(err: dict) -> str:
    """What a field that does not match its pattern needs: the id rule for ids, "not blank" for a text that
    must say something (a correction's reason), never the id rule for another field."""
    pattern = (err.get("ctx") or {}).get("pattern")
    if pattern == r"\S":
        return "must not be blank: say why"
    return ID_WORDS if pattern == ID_PATTERN else "does not have the expected form"


def jsonable(errors) -> list[dict]:
    """The errors without the client's ``input`` (and ``ctx``, which may quote it)."""
    return [{k: (v[:200] if isinstance(v, str) else [str(p)[:80] for p in v] if k == "loc" else v)
             for k, v in e.items() if k in ("type", "loc", "msg")} for e in errors]


def _catalog_unreachable(exc: OperationalError) -> JSONResponse:
    """503 naming the catalog's failure (its first line: no statement, no parameters); a recording goes on."""
    words = str(exc.orig or exc).strip().splitlines()[0][:300]
    log.error("catalog unreachable: %s", words)
    return JSONResponse(status_code=503, content={"detail": f"the catalog is unreachable ({words}); a recording "
                                                            "goes on: try again when it is back"})


def create_app(settings: Settings, link=None, *, scene=None) -> FastAPI:
    """Build the app; the catalog opens (and its schema is checked) at start-up. ``scene``: a
    :class:`gaitcap.services.live.protocols.SceneControl` for simulated cameras (None: nothing to switch)."""

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI):
        app.state.catalog = cat.open_catalog(settings.catalog_url)
        audit_rows = AuditQueue(app.state.catalog).start()  # a read never waits for the write lock
        log.info("catalog %s, data %s", app.state.catalog.shown_url, settings.data_dir)
        room, live = settings.room, app.state.link.connected
        if live:  # a capture room (a catalog-only server records nothing: it is no room)
            cat.register_room(app.state.catalog, room, host=socket.gethostname())
        app.state.pending_stops = PendingStops(app.state.catalog).start()  # Stops made while it is unreachable
        guard = TrialGuard(app.state.catalog, app.state.link, room=room,
                           pending=app.state.pending_stops.ids).start() if live else None
        reporter = RoomReporter(app.state.catalog, app.state.link, room).start() if live else None
        backups = start_backups(settings)
        try:
            yield
        finally:
            if backups is not None:
                backups.stop()
            if guard is not None:
                guard.close()
            if reporter is not None:
                reporter.close()
            app.state.pending_stops.close()
            audit_rows.close()
            app.state.catalog.close()
            app.state.link.close()

    app = FastAPI(title="gaitcap clinic API", version="1", lifespan=lifespan, docs_url=None, redoc_url=None,
                  description="Start and stop gait trials, follow processing, fetch gait metrics and files. "
                              "Sign in with POST /login (session cookie) or send a user's API token "
                              "(Authorization: Bearer); each route needs a role's permission.")
    app.state.settings = settings
    install_security(app, settings)
    app.state.link = link if link is not None else NoLink()
    app.state.scene = scene if scene is not None else NoScene()
    app.add_exception_handler(RequestValidationError, lambda _r, exc: _field_errors(exc))
    app.add_exception_handler(OperationalError, lambda _r, exc: _catalog_unreachable(exc))
    app.add_exception_handler(ValueError, lambda _r, exc: JSONResponse(status_code=422,
                                                                       content={"detail": str(exc)[:300]}))
    app.include_router(routes_trials.router)
    app.include_router(routes_results.router)
    app.include_router(routes_kinematics.router)
    app.include_router(routes_live.router)
    app.include_router(routes_calibrations.router)
    app.include_router(routes_rig_check.router)
    app.include_router(routes_calibration_versions.router)
    app.include_router(routes_people.router)
    app.include_router(routes_report.router)
    app.include_router(routes_validation.router)
    app.include_router(routes_patients.router)
    app.include_router(routes_rooms.router)
    app.mount("/static", StaticFiles(directory=STATIC), name="static")

    @app.get("/health", tags=["health"], summary="Each component's state (no token needed)")
    def health(request: Request) -> dict:
        """``status`` ok | degraded; ``components``: database, disk, recorder, detector, workers, cameras."""
        return health_report(request.app.state.catalog, request.app.state.link, settings.data_dir,
                             min_free_bytes=int(settings.min_free_mb * 2**20))

    @app.get("/", include_in_schema=False)
    def page() -> FileResponse:
        return FileResponse(STATIC / "index.html", media_type="text/html")

    return app
