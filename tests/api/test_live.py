"""Live routes: the status WebSocket, preview WebSocket and MJPEG stream, camera health."""

import json

import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from .conftest import signed_in


def _cookie(url: str) -> dict:
    with signed_in(url) as c:
        return {"Cookie": f"gaitcap_session={c.cookies['gaitcap_session']}"}


def test_status_websocket_sends_trials_and_cameras(server):
    srv, client, _, _ = server
    ws_url = srv.url.replace("http", "ws")
    tid = client.post("/trials", json={"subject_id": "P3"}).json()["id"]
    cookie = _cookie(srv.url)
    with connect(f"{ws_url}/ws/status", additional_headers=cookie) as ws:
        snap = json.loads(ws.recv(timeout=5))
    assert snap["recording"]["id"] == tid and snap["trials"][0]["state_text"] == "Recording"
    assert [(c["name"], c["healthy"]) for c in snap["cameras"]] == [("cam0", True), ("cam1", False)]
    with pytest.raises(InvalidStatus, match="403"):  # not signed in: refused before accept
        with connect(f"{ws_url}/ws/status") as ws:
            ws.recv(timeout=5)
    with pytest.raises(InvalidStatus, match="403"):  # signed in, but from another site's page
        with connect(f"{ws_url}/ws/status", additional_headers=cookie, origin="http://evil.example") as ws:
            ws.recv(timeout=5)


def test_preview_websocket_and_mjpeg(server):
    srv, client, link, _ = server
    with connect(f"{srv.url.replace('http', 'ws')}/ws/preview", additional_headers=_cookie(srv.url)) as ws:
        msg = ws.recv(timeout=5)
    n = msg[0]
    assert msg[1:1 + n].decode() in ("cam0", "cam1") and msg[1 + n:] == link.jpeg
    assert client.get("/cameras/cam0/preview.jpg").content == link.jpeg
    assert client.get("/cameras/nope/preview.jpg").status_code == 404
    with client.stream("GET", "/cameras/cam0/preview.mjpg", timeout=5) as r:
        assert r.headers["content-type"].startswith("multipart/x-mixed-replace")
        first = next(r.iter_bytes())
    assert first.startswith(b"--gaitcapframe") and link.jpeg in first
