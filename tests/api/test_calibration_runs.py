"""Calibrate from the API against the real stack (simulated cameras, recorder, API as processes; Zenoh on
loopback; SQLite; the clinic page in headless Chromium): press Calibrate, let the simulated cameras show
the board, press Stop; the calibration job computes it, the page shows pass per camera, it becomes
active and is close to the simulated rig; one recording (trial or board) at a time.

Bound: camera centres within 100 mm and rotations within 1 deg of the truth, the same bound as the
calibration CLI's test for a short (6 s, 60 frame) low-resolution (576x360) clip; the full-size
targets need the long clip of the calibration benchmark.
"""

import time

import httpx
import numpy as np
import pytest
from gaitcap.acquisition.drivers.simulated import SimTrialSpec
from gaitcap.acquisition.readers import load_rig
from gaitcap.reconstruction.calibration.geometry import rotation_angle_deg
from gaitcap.services.bus.session import free_loopback_ports
from gaitcap.services.ops.stack import Stack, StackConfig
from gaitcap.simulator.board import scaled_rig

from .conftest import sign_in_page

TOKEN = "calibration-test-token"
BROWSER_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--no-first-run"]
CAMERAS, FPS, SIZE = 6, 10.0, (576, 360)


@pytest.fixture(scope="module")
def stack(tmp_path_factory):
    base = free_loopback_ports(12)[0]
    cfg = StackConfig(data_dir=tmp_path_factory.mktemp("clinic"), token=TOKEN, port=base, bus_base_port=base + 1,
                      cameras=CAMERAS, size=f"{SIZE[0]}x{SIZE[1]}", fps=FPS, sim_seconds=120.0, refine=False)
    s = Stack(cfg)
    s.start(timeout_s=240)
    try:
        yield s
    finally:
        s.stop()


@pytest.fixture
def client(stack):
    with stack.client() as c:
        yield c


def test_calibrate_from_the_page_gives_the_active_calibration(stack, client, tmp_path):
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=BROWSER_ARGS)
        page = browser.new_page(viewport={"width": 1280, "height": 1400})
        page.set_default_timeout(30_000)
        try:
            sign_in_page(page, stack.page_url, "demo", TOKEN)
            page.click("#calibrate")
            page.wait_for_function("() => document.querySelector('#calibration-status').textContent"
                                   ".includes('Recording the board')")
            cal_id = client.get("/calibrations").json()[0]["id"]
            assert client.post("/trials", json={"subject_id": "P1"}).status_code == 409  # the board records
            assert client.post("/calibrations/record/start").status_code == 409
            started = time.monotonic()
            _board_coverage_is_shown(page, client, cal_id)
            time.sleep(max(0.0, 6.5 - (time.monotonic() - started)))  # the board clip: 60 frames at 10 frames/s
            page.click("#calibrate-stop")
            page.wait_for_function("() => document.querySelector('#calibration-status').textContent"
                                   ".startsWith('Calibrating')")
            assert client.post("/calibrations/record/stop").status_code == 409  # nothing records now
            page.wait_for_function("() => document.querySelector('#calibration-status').textContent"
                                   ".startsWith('Calibration ')", timeout=300_000)  # passed / failed
            cells = page.locator("#calibration-table tbody tr td:nth-child(2)").all_inner_texts()
            assert cells == ["pass"] * CAMERAS, page.inner_text("#calibrate-card")
            assert "next trials use it" in page.inner_text("#calibration-status")
        finally:
            page.screenshot(path=str(tmp_path / "calibration.png"), full_page=True)
            browser.close()
    run = client.get(f"/calibrations/{cal_id}").json()
    assert run["state"] == "done", run["error"]
    assert run["active"] and client.get("/calibrations/latest").json()["id"] == cal_id
    report = run["report"]
    assert [c["name"] for c in report["cameras"]] == [f"cam{i:02d}" for i in range(1, CAMERAS + 1)]
    assert all(c["ok"] and c["n_detections"] >= 5 for c in report["cameras"])
    listed = client.get("/calibrations").json()
    assert listed[0]["id"] == cal_id and any(c["kind"] == "uploaded" for c in listed)
    toml = client.get(f"/calibrations/{cal_id}/toml")
    assert toml.status_code == 200 and "attachment" in toml.headers["content-disposition"]
    (tmp_path / "got.toml").write_text(toml.text)
    got = load_rig(tmp_path / "got.toml")
    truth = scaled_rig(SimTrialSpec(cameras=CAMERAS, fps=FPS, seconds=5.0).make().rig, SIZE[0] / 1920)
    for true, cam in zip(truth, got, strict=True):
        assert np.linalg.norm(true.center_mm - cam.center_mm) < 100, true.name
        assert rotation_angle_deg(true.rotation, cam.rotation) < 1.0, true.name
    actions = [e["action"] for e in client.get("/audit").json()]
    assert "calibrate start" in actions and "calibrate stop" in actions


def _board_coverage_is_shown(page, client, cal_id: str) -> None:
    """While the board records, the page draws each camera's grid of board views and the pair table from
    GET /calibrations/record/coverage, whose counts agree with each other."""
    page.wait_for_function("() => [...document.querySelectorAll('#calibration-grids figcaption')]"
                           ".some((f) => !/: 0 views/.test(f.textContent))", timeout=60_000)  # spare CPU only
    cov = client.get("/calibrations/record/coverage").json()
    names = [f"cam{i:02d}" for i in range(1, CAMERAS + 1)]
    assert cov["id"] == cal_id and [c["name"] for c in cov["cameras"]] == names and cov["grid"] == 4
    assert sum(c["views"] for c in cov["cameras"]) >= 1
    for c in cov["cameras"]:
        cells = np.array(c["cells"])
        assert cells.shape == (4, 4) and c["views"] <= c["looked"] and cells.max(initial=0) <= c["views"] <= cells.sum()
    views = {c["name"]: c["views"] for c in cov["cameras"]}
    assert len(cov["pairs"]) == CAMERAS * (CAMERAS - 1) // 2
    assert all(p["together"] <= min(views[p["cameras"][0]], views[p["cameras"][1]]) for p in cov["pairs"])
    assert page.locator("#calibration-grids figure").count() == CAMERAS
    assert page.locator("#calibration-pairs tbody tr").count() == CAMERAS


def test_no_board_recording_while_a_trial_records(client):
    trial = client.post("/trials", json={"subject_id": "P2"})
    assert trial.status_code == 201, trial.text
    try:
        r = client.post("/calibrations/record/start")
        assert r.status_code == 409 and trial.json()["id"] in r.json()["detail"]
    finally:
        client.post(f"/trials/{trial.json()['id']}/stop")


def test_unknown_calibration_and_auth(client, stack):
    assert client.get("/calibrations/C20000101-000000-abcdef").status_code == 404
    assert client.get("/calibrations/bad id!").status_code == 422
    assert httpx.get(f"{stack.cfg.url}/calibrations").status_code == 401


def test_a_failed_calibration_is_kept_with_its_reason_and_not_used(server):
    """Real uvicorn + catalog; Stop queues a calibrate job that a worker (here in the test) takes; the
    recorder is the in-test link (it writes no file), so the job fails naming the missing recording, and
    the previous calibration stays in use. The API starts no process of its own."""
    from gaitcap.services import catalog as cat
    from gaitcap.services.processing.worker import Worker, WorkerConfig

    _, c, link, settings = server
    assert c.get("/calibrations/record/stop").status_code == 405
    assert c.post("/calibrations/record/stop").status_code == 409  # nothing records
    run = c.post("/calibrations/record/start").json()
    assert link.calls[-1][0] == "start" and link.calls[-1][3]["kind"] == "calibration"
    assert c.post("/trials", json={"subject_id": "P3"}).status_code == 409
    assert c.post("/calibrations/record/stop").json()["state"] == "calibrating"
    db = cat.open_catalog(settings.catalog_url)
    assert [(j.kind, j.state) for j in cat.jobs_for_calibration(db, run["id"])] == [("calibrate", "queued")]
    time.sleep(0.5)
    assert c.get(f"/calibrations/{run['id']}").json()["state"] == "calibrating"  # nobody but a worker computes it
    assert Worker(WorkerConfig(catalog_url=settings.catalog_url, data_dir=settings.data_dir, refine=False), db=db).run_once()
    got = c.get(f"/calibrations/{run['id']}").json()
    assert got["state"] == "failed" and "does not exist" in got["error"] and not got["active"], got
    assert got["kind"] == "board recording" and got["started_by"] == "alice"
    assert c.get("/calibrations/latest").status_code == 404
    assert c.get(f"/calibrations/{run['id']}/toml").status_code == 404
    assert c.post("/trials", json={"subject_id": "P3"}).status_code == 201  # the slot is free again
