"""``GET /calibrations/record/coverage``: while a board recording runs, the board views the detector nodes
reported, per camera cell and camera pair, with advice; the board recording's Start asks the live system
to look for its board and Stop to stop; 409 without a board recording. Real uvicorn and SQLite; the live
system is the API tests' recording link (the whole chain, detector node to page, runs in
test_calibration_runs.py)."""

import httpx
from gaitcap.reconstruction.calibration.coverage import BoardSighting

BOARD = {"kind": "checkerboard", "squares": [8, 6], "square_mm": 100.0}


def test_coverage_while_a_board_recording_runs(server):
    srv, client, link, _ = server
    none = client.get("/calibrations/record/coverage")
    assert none.status_code == 409 and none.json()["detail"] == "no board recording is under way"
    started = client.post("/calibrations/record/start", json={"board": BOARD}).json()
    cal_id = started["id"]
    assert started["board"]["squares"] == [8, 6] and ("watch board", cal_id, started["board"]) in link.board_calls
    link.board_looked.update(cam0=3, cam1=3)
    link.board_sightings += [BoardSighting("cam0", 0, (0, 1)), BoardSighting("cam1", 1000, (15,)),
                             BoardSighting("cam0", 10**9, (0, 5))]
    got = client.get("/calibrations/record/coverage").json()
    assert got["id"] == cal_id and got["grid"] == 4 and got["moments"] == 2 and got["slot_s"] == 0.5
    cams = {c["name"]: c for c in got["cameras"]}
    assert cams["cam0"]["views"] == 2 and cams["cam0"]["looked"] == 3 and cams["cam0"]["cells"][0] == [2, 1, 0, 0]
    assert cams["cam1"]["cells"][3] == [0, 0, 0, 1]
    assert got["pairs"] == [{"cameras": ["cam0", "cam1"], "together": 1}]
    assert "cam1: no views in the upper left, top, upper right, left, centre, right, lower left, bottom" in got["advice"]
    client.post("/calibrations/record/stop")
    assert ("unwatch board", cal_id) in link.board_calls
    assert client.get("/calibrations/record/coverage").status_code == 409
    # the next board recording: its own views (none yet), cameras nobody looked at named first
    client.post("/calibrations/record/start")
    assert ("watch board", link.board_watched, None) in link.board_calls  # no board given: the default board
    link.board_looked.update(cam0=1)
    got = client.get("/calibrations/record/coverage").json()
    assert got["advice"][:2] == ["cam1: no frame looked at for the board yet (the detector nodes look about "
                                 "every 0.5 s)", "cam0: no board view yet: show it the board"]
    link.board_watched = "C-another"  # e.g. this server restarted during the recording: it follows none
    lost = client.get("/calibrations/record/coverage")
    assert lost.status_code == 503 and "its board views are not followed by this server" in lost.json()["detail"]
    assert httpx.get(srv.url + "/calibrations/record/coverage").status_code == 401
