"""HTTP front end (FastAPI): REST API, WebSocket status, the clinician web page."""
