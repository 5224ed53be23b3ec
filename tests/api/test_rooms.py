"""Two capture rooms on one PostgreSQL catalog, each with its own API (real uvicorn) and its own recorder and
cameras (the in-test link): both record at once, each Start and Stop reaches only its own room's recorder, a
Stop of another room's trial is refused, the page's lists filter by room and show each room's rig state,
each API's audit chain verifies, and no database password reaches a page."""

import re
import time

import httpx
import pytest
from gaitcap.api.audit_chain import verify
from gaitcap.api.server import serve_in_thread
from gaitcap.api.settings import Settings
from gaitcap.services.bus.session import free_loopback_ports
from gaitcap.services.live.protocols import CameraHealth

from .conftest import ALL_ROLES, TOKEN, RecordingLink, make_accounts


def _room(tmp_path, catalog_url, name, port, cameras):
    data = tmp_path / name
    make_accounts(data, alice=ALL_ROLES)
    settings = Settings(tokens={TOKEN: "alice"}, catalog_url=catalog_url, data_dir=data, port=port,
                        status_period_s=0.1, room=name)
    link = RecordingLink()
    if cameras:
        link.camera_list = [CameraHealth(f"cam{i}", 30.0, True, "ok", 0.01) for i in range(cameras)]
    srv = serve_in_thread(settings, link)
    return srv, link, httpx.Client(base_url=srv.url, headers={"Authorization": f"Bearer {TOKEN}"}, timeout=60)


def test_two_rooms_on_one_postgresql_catalog_never_touch_each_others_recorder(postgres, tmp_path):
    url = postgres.create_database("two_rooms")
    ports = free_loopback_ports(2)
    srv_a, link_a, a = _room(tmp_path, url, "gait1", ports[0], cameras=0)  # the in-test link's two cameras
    srv_b, link_b, b = _room(tmp_path, url, "gait2", ports[1], cameras=3)
    try:
        ta = a.post("/trials", json={"subject_id": "P0001", "session": "v1"})
        tb = b.post("/trials", json={"subject_id": "P0002", "session": "v1"})
        assert ta.status_code == tb.status_code == 201, (ta.text, tb.text)
        ta, tb = ta.json(), tb.json()
        assert (ta["room"], tb["room"]) == ("gait1", "gait2")
        assert [c[:2] for c in link_a.calls] == [("start", ta["id"])] and [c[:2] for c in link_b.calls] == [
            ("start", tb["id"])]
        assert a.post("/trials", json={"subject_id": "P0003", "session": "v1"}).status_code == 409  # gait1 busy
        assert a.get("/status").json()["recording"]["id"] == ta["id"]
        assert b.get("/status").json()["recording"]["id"] == tb["id"]
        refused = a.post(f"/trials/{tb['id']}/stop")
        assert refused.status_code == 409 and "room gait2" in refused.json()["detail"]
        assert len(link_b.calls) == 1 and b.get(f"/trials/{tb['id']}").json()["state"] == "recording"
        assert [t["id"] for t in a.get("/trials", params={"room": "gait2"}).json()] == [tb["id"]]
        assert {t["id"] for t in a.get("/trials").json()} == {ta["id"], tb["id"]}  # any patient from any room
        shown = {r["name"]: r for r in a.get("/rooms").json()}
        assert set(shown) == {"gait1", "gait2"} and shown["gait1"]["this_room"] and not shown["gait2"]["this_room"]
        assert (shown["gait2"]["recording"], shown["gait2"]["cameras_seen"], shown["gait1"]["cameras_healthy"]) == (
            tb["id"], 3, 1)
        assert a.post(f"/trials/{ta['id']}/stop").json()["state"] == "recorded"
        assert link_a.calls[-1] == ("stop", ta["id"]) and len(link_b.calls) == 1
        assert b.post(f"/trials/{tb['id']}/stop").json()["state"] == "recorded"
        secret = postgres.password()
        for client in (a, b):
            for path in ("/health", "/status", "/rooms", "/"):
                assert secret not in client.get(path).text
        srv_b.stop()  # room gait2's host gone: its trials stay readable from any other room
        assert a.get(f"/trials/{tb['id']}").json()["state"] == "recorded"
        assert [t["id"] for t in a.get("/trials", params={"room": "gait2"}).json()] == [tb["id"]]
        assert {r["name"]: r["recording"] for r in a.get("/rooms").json()} == {"gait1": None, "gait2": None}
    finally:
        for client, srv in ((a, srv_a), (b, srv_b)):
            client.close()
            srv.stop()
    for name in ("gait1", "gait2"):
        checked, problem = verify(tmp_path / name / "audit.log")
        assert problem is None and checked >= 3


OUTAGE_S = 2.0  # how long the database server is stopped here; bench/rooms_faults.py runs the 60 s outage


def test_the_catalog_gone_during_a_recording_loses_nothing(tmp_path):
    """The database server stopped (OUTAGE_S) while a room records (its own server: the session's is left
    alone): the recorder goes on; /health and the page's banner say the catalog is unreachable; the lists
    answer 503 naming the catalog; Stop on the page stops the recorder at once (202, "Saved. The catalog is
    unreachable ...") and its catalog writes wait and are retried: once the server is back, without anyone pressing anything, the trial is recorded with the
    recorder's summary and its processing queued, the Stop in the audit rows."""
    from gaitcap.services import catalog as cat
    from gaitcap.services.ops.pg_server import LocalPostgres

    from .conftest import signed_in_page

    with LocalPostgres() as pg:
        url = pg.create_database("gone")
        with pytest.MonkeyPatch.context() as patch:
            for name, value in pg.environment().items():
                patch.setenv(name, value)
            srv, link, client = _room(tmp_path, url, "gait1", free_loopback_ports(1)[0], cameras=0)
            try:
                trial = client.post("/trials", json={"subject_id": "P0001", "session": "v1"}).json()
                with signed_in_page(srv.url, timeout_ms=15_000) as page:  # the page, at 1280 px
                    page.wait_for_function("() => document.querySelector('#record-status').textContent"
                                           ".includes('Recording')")
                    pg.pause()
                    t_down = time.monotonic()
                    database = client.get("/health").json()["components"]["database"]
                    assert database["ok"] is False and database["status"].startswith("the catalog is unreachable")
                    assert client.get("/trials").status_code == 503
                    assert link.recording == trial["id"] and [c[0] for c in link.calls] == ["start"]  # recording on
                    shown = page.wait_for_selector("#system:not([hidden]) li[data-component='database']")
                    assert "Database: the catalog is unreachable" in shown.inner_text()
                    page.click("#stop")  # Stop on the page: saved at once, the catalog's writes wait
                    page.wait_for_function("() => document.querySelector('#record-status').textContent"
                                           ".startsWith('Saved. The catalog is unreachable')")
                    assert "written and queued for processing as soon as it is back" in page.inner_text(
                        "#record-status")
                assert link.calls[-1] == ("stop", trial["id"]) and link.recording is None  # the file is finished
                time.sleep(max(0.0, OUTAGE_S - (time.monotonic() - t_down)))
                assert client.post(f"/trials/{trial['id']}/stop").status_code == 202  # pressed again: no harm
                pg.resume()
                db = cat.open_catalog(url)
                end = time.monotonic() + 30
                while cat.get_trial(db, trial["id"]).state in ("recording", "stopping") and time.monotonic() < end:
                    time.sleep(0.2)
                written = cat.get_trial(db, trial["id"])
                assert written.state == "recorded" and written.stopped_at is not None, written
                assert cat.get_quality(db, trial["id"])["recorder"]["frames"] == 10  # the recorder's summary
                assert [j.state for j in cat.jobs_for_trial(db, trial["id"])] == ["queued"]
                stops = [e for e in cat.audit_entries(db, trial_id=trial["id"]) if e.action == "stop"]
                assert [e.actor for e in stops] == ["alice"], stops
                assert client.get(f"/trials/{trial['id']}").json()["state"] == "recorded"
                assert [c[0] for c in link.calls] == ["start", "stop", "stop"]
                db.close()
            finally:
                client.close()
                srv.stop()


def _finished_with_rig_check(db, room: str, moved: list[str]) -> str:
    """A processed trial of ``room`` whose stored quality holds a rig check (the worker's record's shape)."""
    from gaitcap.services import catalog as cat

    t = cat.start_trial(db, subject_id="P0099", session="v0", room=room,
                        recording_path_for=lambda tid: f"/nowhere/{tid}.mcap")
    for state in ("recorded", "processing", "done_with_warnings"):
        cat.set_state(db, t.id, state)
    cat.set_quality(db, t.id, "processing", {"warnings": [], "checks": {"rig": {
        "run": True, "flagged": bool(moved), "moved": moved, "cameras": {}}}})
    return t.id


def test_the_page_shows_each_rooms_rig_and_filters_trials_by_room(postgres, tmp_path):
    """Room gait1's page at 1280 px (headless Chromium): a panel per room with its cameras (gait1's slow
    camera named), the trial recording there and its own latest rig check (gait2's moved camera, never
    gait1's); a room whose stack has not written its state for a minute said to be maybe down; the trial list
    filtered to gait2 shows gait2's trials only; Start on gait1's page records in gait1 and never reaches
    gait2's recorder; the page's own rig check is gait1's."""
    from gaitcap.services import catalog as cat
    from gaitcap.services.catalog.models import Room
    from sqlalchemy import update

    from .conftest import signed_in_page
    from .test_clinic_page import _fits

    url = postgres.create_database("rooms_page")
    ports = free_loopback_ports(2)
    srv_a, link_a, a = _room(tmp_path, url, "gait1", ports[0], cameras=0)  # cam1 at a low frame rate
    srv_b, link_b, b = _room(tmp_path, url, "gait2", ports[1], cameras=3)
    db = cat.open_catalog(url)
    try:
        checked_b = _finished_with_rig_check(db, "gait2", ["cam2"])
        checked_a = _finished_with_rig_check(db, "gait1", [])
        cat.register_room(db, "gait3", host="room3")  # its stack last wrote its state a minute ago
        with db.session() as s:
            s.execute(update(Room).where(Room.name == "gait3").values(seen_at=time.time() - 60))
        tb = b.post("/trials", json={"subject_id": "P0002", "session": "v1"}).json()
        with signed_in_page(srv_a.url, width=1280, height=1000, timeout_ms=15_000) as page:
            page.wait_for_selector("#rooms-card:not([hidden]) .room-panel[data-room='gait2']")
            panel = {n: page.locator(f".room-panel[data-room='{n}']") for n in ("gait1", "gait2")}
            assert panel["gait2"].locator(".room-recording").inner_text() == f"Recording trial {tb['id']}"
            assert panel["gait2"].locator(".room-cameras").inner_text() == "3 of 3 cameras working"
            assert panel["gait1"].locator(".room-cameras").inner_text() == (
                "1 of 2 cameras working; not working: cam1 (low frame rate)")
            assert panel["gait2"].locator(".room-rig-check").inner_text() == (
                f"Camera cam2 moved since calibration (trial {checked_b}).")
            assert panel["gait1"].locator(".room-rig-check").inner_text() == (
                f"No camera moved since calibration (trial {checked_a}).")
            assert "This page's room" in panel["gait1"].inner_text()
            assert "This page's room" not in panel["gait2"].inner_text()
            gone = re.fullmatch(r"Not seen for (\d+) s: its stack or host may be down; its trials stay readable here\.",
                                page.locator(".room-panel[data-room='gait3'] p.error").inner_text())
            assert gone and int(gone[1]) >= 60, gone
            assert not [n for n in ("gait1", "gait2") if panel[n].locator("p.error").count()]
            page.wait_for_selector("#rig-check:not([hidden])")  # the record card's check is this room's own
            assert f"trial {checked_a}" in page.inner_text("#rig-check-summary")
            _fits(page, 1280, "rooms at 1280 px")

            def listed():
                return sorted(page.eval_on_selector_all("#trials tbody tr[data-trial]", "rs => rs.map(r => r.dataset.trial)"))

            page.wait_for_selector(f"#trials tr[data-trial='{checked_a}']")
            assert listed() == [checked_a]  # this room's live list
            page.select_option("#trials-room", "room:gait2")
            page.wait_for_selector(f"#trials tr[data-trial='{tb['id']}']")
            page.wait_for_timeout(600)  # several status snapshots (this room's, every 0.1 s) later: still gait2's
            assert listed() == sorted([tb["id"], checked_b])

            page.fill("#subject", "P0001")
            page.once("dialog", lambda d: d.accept())  # the rig check's question (gait1's cam1 is slow)
            page.click("#start")
            page.wait_for_function("() => document.querySelector('#record-status').textContent.includes('Recording')")
            started = [c for c in link_a.calls if c[0] == "start"]
            assert len(started) == 1 and [c[:2] for c in link_b.calls] == [("start", tb["id"])]  # gait2 untouched
            page.wait_for_function("() => document.querySelector(\".room-panel[data-room='gait1'] .room-recording\")"
                                   f".textContent === 'Recording trial {started[0][1]}'")
            assert panel["gait2"].locator(".room-recording").inner_text() == f"Recording trial {tb['id']}"
            page.select_option("#trials-room", "")
            page.wait_for_selector(f"#trials tr[data-trial='{started[0][1]}']")
            assert listed() == sorted([checked_a, started[0][1]])
        assert [c[:2] for c in link_b.calls] == [("start", tb["id"])]
    finally:
        db.close()
        for client, srv in ((a, srv_a), (b, srv_b)):
            client.close()
            srv.stop()
