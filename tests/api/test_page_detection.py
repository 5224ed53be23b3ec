"""The clinic page shows each camera's live detection (share of frames with keypoints, lag) in a real
browser (Chromium via Playwright) against a real uvicorn, from the status the API sends."""

from .conftest import sign_in_page

ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run"]
ROW = {"node": "detector", "received": 200, "detected": 190, "skipped": 10, "lost": 0, "failed": 0, "lag_s": 0.42,
       "coverage": 0.95}


def test_each_camera_tile_shows_its_live_keypoints_and_lag(server):
    from playwright.sync_api import sync_playwright

    srv, client, link, _ = server
    link.detection = lambda: {"nodes": {"detector": {"workers": 2, "pool": 2, "age_s": 0.3, "stale": False}},
                              "cameras": {"cam0": ROW}}
    assert client.get("/status").json()["detection"]["cameras"]["cam0"]["coverage"] == 0.95
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=ARGS)
        page = browser.new_page(viewport={"width": 390, "height": 844})
        page.set_default_timeout(30_000)
        try:
            sign_in_page(page, srv.url)
            page.wait_for_function("() => (document.querySelector(\".camera[data-camera='cam0'] .det\") || {})"
                                   ".textContent === 'Keypoints live: 95 %, 0.4 s behind'")
            assert page.inner_text(".camera[data-camera='cam1'] .det") == ""  # no detection reported for cam1
        finally:
            browser.close()


def test_health_names_a_detector_whose_worker_processes_are_all_gone(server):
    import httpx

    srv, _, link, _ = server
    nodes = {"detector": {"workers": 2, "pool": 2, "age_s": 0.3, "stale": False}}
    link.detection = lambda: {"nodes": nodes, "cameras": {"cam0": ROW}}
    det = httpx.get(f"{srv.url}/health").json()["components"]["detector"]
    assert det["ok"] is True and (det["workers"], det["pool"], det["lag_s"]) == (2, 2, 0.42)
    nodes["detector"] = {**nodes["detector"], "workers": 0}
    det = httpx.get(f"{srv.url}/health").json()["components"]["detector"]
    assert det["ok"] is False and det["status"] == "running, but none of its 2 detector worker processes is alive"
