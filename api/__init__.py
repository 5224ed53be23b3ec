"""HTTP only: the FastAPI app (REST, WebSockets, the clinic web page). Talks to data through the
catalog and to the live system through ``services.live`` links; never imports ``acquisition``."""
