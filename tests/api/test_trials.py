"""REST API against a real uvicorn and a real SQLite file: auth, start/stop, 409, validation, audit."""

import concurrent.futures

import httpx
from gaitcap.services import catalog as cat

from .conftest import TOKEN


def test_health_needs_no_token_but_everything_else_does(server):
    srv, client, _, _ = server
    health = httpx.get(f"{srv.url}/health").json()
    assert health["status"] == "degraded"  # camera cam1 is not working
    assert health["components"]["cameras"]["not_working"] == {"cam1": "low frame rate"}
    assert all(health["components"][c]["ok"] for c in ("database", "recorder", "detector", "workers"))
    for path in ("/trials", "/cameras", "/status", "/audit", "/trials/T1/gait"):
        r = httpx.get(f"{srv.url}{path}")
        assert r.status_code == 401 and "not signed in" in r.json()["detail"], path
    assert httpx.get(f"{srv.url}/trials", headers={"Authorization": "Bearer wrong-token-xx"}).status_code == 401
    assert httpx.get(f"{srv.url}/trials", params={"token": TOKEN}).status_code == 401  # never in a URL
    assert httpx.get(f"{srv.url}/trials", headers={"Authorization": f"Bearer {TOKEN}"}).status_code == 200
    assert "Start recording" in httpx.get(f"{srv.url}/").text
    assert httpx.get(f"{srv.url}/openapi.json").json()["info"]["title"] == "gaitcap clinic API"


def test_start_stop_queues_processing_and_tells_the_recorder(server):
    _, client, link, settings = server
    r = client.post("/trials", json={"subject_id": "P0042", "session": "visit1"})
    assert r.status_code == 201, r.text
    trial = r.json()
    assert trial["state"] == "recording" and trial["state_text"] == "Recording"
    kind, tid, path, meta = link.calls[0]
    assert (kind, tid) == ("start", trial["id"]) and path.endswith(f"trials/{tid}/recording.mcap")
    assert meta["subject_id"] == "P0042" and meta["started_by"] == "alice"
    r = client.post(f"/trials/{tid}/stop")
    assert r.status_code == 200 and r.json()["state"] == "recorded"
    assert link.calls[1] == ("stop", tid)
    db = cat.open_catalog(settings.catalog_url)
    assert [j.state for j in cat.jobs_for_trial(db, tid)] == ["queued"]
    again = client.post(f"/trials/{tid}/stop")  # a client retry: the same trial, nothing done twice
    assert again.status_code == 200 and again.json()["state"] == "recorded" and link.calls[2:] == []
    assert [t["id"] for t in client.get("/trials").json()] == [tid]
    assert client.get(f"/trials/{tid}").json()["subject_id"] == "P0042"
    actions = [(e["actor"], e["action"]) for e in client.get("/audit", params={"trial_id": tid}).json()]
    assert actions == [("alice", "view"), ("alice", "stop"), ("alice", "start")]


def test_second_start_while_recording_is_409(server):
    _, client, _, _ = server
    first = client.post("/trials", json={"subject_id": "P1"}).json()
    r = client.post("/trials", json={"subject_id": "P2"})
    assert r.status_code == 409 and first["id"] in r.json()["detail"]


def test_two_clients_pressing_start_at_once_get_one_409(server):
    srv, _, link, _ = server

    def press(i):
        with httpx.Client(base_url=srv.url, headers={"Authorization": f"Bearer {TOKEN}"}) as c:
            return c.post("/trials", json={"subject_id": f"P{i}"}).status_code

    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        codes = sorted(pool.map(press, range(2)))
    assert codes == [201, 409]
    assert len([c for c in link.calls if c[0] == "start"]) == 1


def test_bad_bodies_and_ids_name_the_field(server):
    _, client, _, _ = server
    r = client.post("/trials", json={"subject_id": "../../etc/passwd"})
    assert r.status_code == 422 and r.json()["detail"].startswith("subject_id:")
    r = client.post("/trials", json={"session": "x"})
    assert r.status_code == 422 and "subject_id" in r.json()["detail"]
    r = client.post("/trials", json={"subject_id": "P1", "name": "John Smith"})
    assert r.status_code == 422 and "name" in r.json()["detail"]
    r = client.post("/trials", content=b"not json", headers={"Content-Type": "application/json"})
    assert r.status_code == 422
    for bad in ("..", "a%2F..%2Fb", "%2E%2E"):
        assert client.get(f"/trials/{bad}/recording").status_code in (404, 422), bad
    r = client.get("/trials/bad..id")
    assert r.status_code == 422 and "trial_id" in r.json()["detail"]
    assert client.get("/trials/T404").status_code == 404
    assert client.get("/trials", params={"limit": 0}).json()["detail"].startswith("limit")


def test_recorder_down_fails_the_trial_with_503(server):
    _, client, link, _ = server
    link.fail = True
    r = client.post("/trials", json={"subject_id": "P1"})
    assert r.status_code == 503 and "recorder" in r.json()["detail"]
    trial = client.get("/trials").json()[0]
    assert trial["state"] == "failed" and "did not answer" in trial["error"]
    link.fail = False
    assert client.post("/trials", json={"subject_id": "P1"}).status_code == 201  # the slot was freed


def test_without_the_bus_start_is_refused_before_a_trial_exists(tmp_path):
    from gaitcap.api.server import serve_in_thread
    from gaitcap.api.settings import Settings
    from gaitcap.services.bus.session import free_loopback_ports

    from .conftest import make_accounts

    make_accounts(tmp_path, bob=("clinician",))
    settings = Settings(tokens={TOKEN: "bob"}, catalog_url=str(tmp_path / "c.sqlite"), data_dir=tmp_path,
                        port=free_loopback_ports(1)[0])
    srv = serve_in_thread(settings)  # no link: catalog only
    try:
        h = {"Authorization": f"Bearer {TOKEN}"}
        assert httpx.get(f"{srv.url}/health").json()["recorder"] is False
        r = httpx.post(f"{srv.url}/trials", json={"subject_id": "P1"}, headers=h)
        assert r.status_code == 503 and "--no-bus" in r.json()["detail"]
        assert httpx.get(f"{srv.url}/trials", headers=h).json() == []
    finally:
        srv.stop()
