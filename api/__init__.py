"""HTTP only: the FastAPI app (REST, WebSockets, the clinic web page). Talks to data through the
catalog and to the live system through ``gaitcap.services.live.protocols`` links; never imports ``acquisition``."""
