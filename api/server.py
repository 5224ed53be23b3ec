"""Running the API under uvicorn (127.0.0.1 by default; HTTPS when the settings name a certificate),
in the foreground or in a thread (tests)."""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import uvicorn
from gaitcap.api.app import create_app
from gaitcap.api.settings import Settings


def uvicorn_config(settings: Settings, link=None, *, scene=None, log_level: str = "warning") -> uvicorn.Config:
    tls = {}
    if settings.tls_enabled:
        tls = {"ssl_certfile": str(settings.tls_cert), "ssl_keyfile": str(settings.tls_key)}
    return uvicorn.Config(create_app(settings, link, scene=scene), host=settings.host, port=settings.port,
                          log_level=log_level, ws="websockets-sansio", lifespan="on", access_log=False,
                          server_header=False, **tls)


def serve(settings: Settings, link=None, *, scene=None, log_level: str = "info") -> None:
    """Serve until interrupted (SIGINT/SIGTERM)."""
    uvicorn.Server(uvicorn_config(settings, link, scene=scene, log_level=log_level)).run()


@dataclass
class ThreadedServer:
    """A uvicorn server in a background thread; ``url`` once started. Stop with :meth:`stop`."""

    server: uvicorn.Server
    thread: threading.Thread

    @property
    def url(self) -> str:
        cfg = self.server.config
        return f"{'https' if cfg.ssl_certfile else 'http'}://{cfg.host}:{cfg.port}"

    def stop(self, timeout_s: float = 10.0, *, grace_s: float = 1.0) -> None:
        """Stop: requests in flight get ``grace_s`` (s) to finish, then connections still open (a page's
        event stream) are closed rather than waited for; at most ``timeout_s`` (s) in all."""
        self.server.should_exit = True
        self.thread.join(min(grace_s, timeout_s))
        if self.thread.is_alive():
            self.server.force_exit = True
            self.thread.join(max(0.0, timeout_s - grace_s))


def serve_in_thread(settings: Settings, link=None, *, timeout_s: float = 20.0) -> ThreadedServer:
    server = uvicorn.Server(uvicorn_config(settings, link))
    thread = threading.Thread(target=server.run, name="gaitcap-api", daemon=True)
    thread.start()
    deadline = time.monotonic() + timeout_s
    while not server.started:
        if not thread.is_alive() or time.monotonic() > deadline:
            raise RuntimeError(f"API did not start on {settings.host}:{settings.port}")
        time.sleep(0.02)
    return ThreadedServer(server, thread)
