"""Trial integrity over REST (real uvicorn, real SQLite; the recorder and cameras stand in at the
hardware edge): concurrent Stops, a recorder gone at Stop, Start refused on a broken rig (and the
audited override), a read-only trials folder, calibrations checked against the rig, /health."""

import concurrent.futures
import os

import httpx
from gaitcap.acquisition.writers import save_rig
from gaitcap.services import catalog as cat
from gaitcap.services.live.nodes import NodeState
from gaitcap.services.live.protocols import CameraHealth, RecorderUnavailable
from gaitcap.services.processing.pipeline import ring_rig

from .conftest import TOKEN


def _cams(n, fps=30.0, down=()):
    return [CameraHealth(f"cam{i}", fps, i not in down, "ok" if i not in down else "no signal", 0.01)
            for i in range(n)]


def _calibrate(client, link, tmp_path, n=4):
    link.camera_list = _cams(n)
    save_rig(ring_rig(n), tmp_path / "rig.toml")
    r = client.post("/calibrations", json={"toml": (tmp_path / "rig.toml").read_text()})
    assert r.status_code == 201, r.text
    return r.json()


def test_eight_concurrent_stops_end_in_exactly_one_processed_trial(server):
    srv, client, link, settings = server
    tid = client.post("/trials", json={"subject_id": "P1"}).json()["id"]

    def press(_):
        with httpx.Client(base_url=srv.url, headers={"Authorization": f"Bearer {TOKEN}"}, timeout=20) as c:
            return c.post(f"/trials/{tid}/stop")

    with concurrent.futures.ThreadPoolExecutor(8) as pool:
        replies = list(pool.map(press, range(8)))
    assert [r.status_code for r in replies] == [200] * 8
    assert {r.json()["state"] for r in replies} <= {"stopping", "recorded"}
    assert [c for c in link.calls if c[0] == "stop"] == [("stop", tid)]
    db = cat.open_catalog(settings.catalog_url)
    assert [j.state for j in cat.jobs_for_trial(db, tid)] == ["queued"]
    assert cat.get_trial(db, tid).state == "recorded"
    db.close()


def test_recorder_gone_at_stop_interrupts_the_trial_and_says_so(server):
    _, client, link, _ = server
    tid = client.post("/trials", json={"subject_id": "P1"}).json()["id"]

    def dead(trial_id):
        raise RecorderUnavailable("no recorder answered within 10 s")

    link.stop = dead
    r = client.post(f"/trials/{tid}/stop")
    assert r.status_code == 503 and "will be recovered" in r.json()["detail"] and tid in r.json()["detail"]
    trial = client.get(f"/trials/{tid}").json()
    assert trial["state"] == "interrupted" and trial["state_text"].startswith("Recorder lost")
    assert client.post(f"/trials/{tid}/stop").json()["state"] == "interrupted"  # answered, nothing done
    assert client.post("/trials", json={"subject_id": "P2"}).status_code == 201  # the slot is free


def test_start_is_refused_on_a_broken_rig_unless_confirmed_and_the_override_is_audited(server, tmp_path):
    _, client, link, _ = server
    _calibrate(client, link, tmp_path)
    link.camera_list = _cams(4, down=(1, 3))
    r = client.post("/trials", json={"subject_id": "P1"})
    assert r.status_code == 409
    assert "2 of the 4 calibrated cameras are not working: cam1 (no signal), cam3 (no signal)" in r.json()["detail"]
    assert client.get("/trials").json() == []
    link.camera_list = _cams(4, fps=12.0)
    r = client.post("/trials", json={"subject_id": "P1"})
    assert r.status_code == 409 and "4 of 4 cameras deliver far below 28 fps: cam0 12 fps" in r.json()["detail"]
    link.camera_list = []
    assert "no camera is delivering images" in client.post("/trials", json={"subject_id": "P1"}).json()["detail"]
    r = client.post("/trials", json={"subject_id": "P1", "override_rig_check": True})  # nothing to record
    assert r.status_code == 409 and "no camera is delivering images" in r.json()["detail"]
    assert "override_rig_check" not in r.json()["detail"] and client.get("/trials").json() == []
    link.camera_list = _cams(4, down=(2,))
    r = client.post("/trials", json={"subject_id": "P1", "override_rig_check": True})
    assert r.status_code == 201
    trial = r.json()
    assert trial["warnings"] == ["Started although 1 of the 4 calibrated cameras are not working: cam2 (no signal)"]
    audit = client.get("/audit", params={"trial_id": trial["id"]}).json()
    assert ("start override", "alice") in [(a["action"], a["actor"]) for a in audit]


def test_an_unwritable_trials_folder_gives_a_clear_error_and_no_phantom_trial(server):
    _, client, _, settings = server
    trials = settings.data_dir / "trials"
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    if os.geteuid() == 0:  # root writes into read-only folders: a file in the folder's place fails the same way
        trials.write_text("not a folder")
    else:
        trials.mkdir()
        trials.chmod(0o555)
    try:
        r = client.post("/trials", json={"subject_id": "P1"})
        assert r.status_code == 507 and "trials folder: cannot write" in r.json()["detail"]
        assert client.get("/trials").json() == []
    finally:
        if trials.is_dir():
            trials.chmod(0o755)
        else:
            trials.unlink()
    assert client.post("/trials", json={"subject_id": "P1"}).status_code == 201  # nothing blocks Start


def test_a_start_failing_inside_the_recorder_leaves_no_recording_trial(server):
    _, client, link, _ = server

    def refuse(**_):
        raise RecorderUnavailable("recorder refused: cannot write /data/trials/x/recording.mcap")

    link.start = refuse
    assert client.post("/trials", json={"subject_id": "P1"}).status_code == 503
    assert [t["state"] for t in client.get("/trials").json()] == ["failed"]


def test_a_calibration_not_matching_the_rig_is_refused_naming_the_cameras(server, tmp_path):
    _, client, link, _ = server
    link.camera_list = _cams(4)
    save_rig(ring_rig(1), tmp_path / "one.toml")
    r = client.post("/calibrations", json={"toml": (tmp_path / "one.toml").read_text()})
    assert r.status_code == 422 and "needs at least 2 cameras, this one has 1" in r.json()["detail"]
    assert "cam1, cam2, cam3 in service but not in the calibration" in r.json()["detail"]
    rig = ring_rig(4)
    save_rig(rig, tmp_path / "other.toml")
    other = (tmp_path / "other.toml").read_text().replace('"cam', '"lab')
    r = client.post("/calibrations", json={"toml": other})
    assert r.status_code == 422 and "lab0, lab1, lab2, lab3 not in the rig" in r.json()["detail"]
    assert client.get("/calibrations/latest").status_code == 404  # nothing became the calibration in use
    r = client.post("/calibrations", json={"toml": other, "camera_map": {f"lab{i}": f"cam{i}" for i in range(4)}})
    assert r.status_code == 201 and r.json()["cameras"] == ["cam0", "cam1", "cam2", "cam3"]
    assert '"cam3"' in client.get("/calibrations/latest").json()["toml"]
    bad = (tmp_path / "other.toml").read_text().replace("error = 0.0", "")
    r = client.post("/calibrations", json={"toml": bad})
    assert r.status_code == 422 and r.json()["detail"].startswith("metadata.error")


def test_health_names_the_component_that_is_down(server):
    srv, _, link, _ = server
    link.camera_list = _cams(2)
    body = httpx.get(f"{srv.url}/health").json()
    assert body["status"] == "ok", {k: v for k, v in body["components"].items() if not v["ok"]}
    assert set(body["components"]) == {"database", "disk", "recorder", "detector", "workers", "cameras"}
    link.up["recorder"] = NodeState("recorder", False, 1_700_000_000.0, True)
    body = httpx.get(f"{srv.url}/health").json()
    assert body["status"] == "degraded" and body["components"]["recorder"]["ok"] is False
    assert body["components"]["recorder"]["status"].startswith("down since")


def test_results_carry_the_warnings_in_json_and_the_csv_header(server):
    _, client, _, settings = server
    tid = client.post("/trials", json={"subject_id": "P7"}).json()["id"]
    client.post(f"/trials/{tid}/stop")
    db = cat.open_catalog(settings.catalog_url)
    quality = {"cameras": [{"name": "cam07", "lost": 156}], "warnings": ["Camera cam07 stopped at 4.2 s"]}
    cat.set_quality(db, tid, "processing", quality)
    cat.store_result(db, trial_id=tid, stage="preliminary", method="m", steps=[{"side": "left", "time_s": 1.0}],
                     summary={}, report={"data_quality": quality})
    db.close()
    g = client.get(f"/trials/{tid}/gait").json()
    assert g["warnings"] == ["Camera cam07 stopped at 4.2 s"] and g["data_quality"]["cameras"][0]["lost"] == 156
    lines = client.get(f"/trials/{tid}/steps", params={"format": "csv"}).text.splitlines()
    assert lines == ["# warning: Camera cam07 stopped at 4.2 s", "side,time_s", "left,1.0"]
