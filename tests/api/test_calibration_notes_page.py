"""The calibration table of the clinic page (real uvicorn, headless Chromium): a camera that passed with a
note (views left out) shows "pass" and its note in the Notes column, with nothing under Problems; a
failed camera's problems stay under Problems. The report is the one a calibration run returns, shown by
the page's own code."""

from gaitcap.reconstruction.calibration.whole_views import LEFT_OUT_REASON

from .conftest import sign_in_page

ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run"]
NOTE = f"3 views left out: {LEFT_OUT_REASON}"
PROBLEM = "reprojection p95 3.50 px > 3.0 px"


def _camera(name: str, ok: bool, problems: list[str], notes: list[str]) -> dict:
    return {"name": name, "ok": ok, "n_detections": 40, "reprojection_mean_px": 0.4, "reprojection_p95_px": 0.9,
            "coverage": 0.6, "problems": problems, "notes": notes}


def test_a_passing_camera_with_a_note_is_not_shown_as_failing(server):
    from playwright.sync_api import sync_playwright

    srv, *_ = server
    run = {"id": "cal-1", "state": "done", "active": True, "has_toml": False, "error": None,
           "report": {"cameras": [_camera("cam01", True, [], [NOTE]), _camera("cam02", False, [PROBLEM], [NOTE])]}}
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=ARGS)
        page = browser.new_page(viewport={"width": 1280, "height": 900})
        page.set_default_timeout(30_000)
        try:
            sign_in_page(page, srv.url)
            page.evaluate("run => showCalibration(run)", run)
            header = page.locator("#calibration-table thead th").all_inner_texts()
            rows = [r.locator("td").all_inner_texts() for r in page.locator("#calibration-table tbody tr").all()]
        finally:
            browser.close()
    problems, notes = header.index("Problems"), header.index("Notes")
    assert [r[header.index("Result")] for r in rows] == ["pass", "FAIL"]
    assert [r[problems] for r in rows] == ["", PROBLEM]
    assert [r[notes] for r in rows] == [NOTE, NOTE]
