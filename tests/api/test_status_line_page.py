"""The record status line follows the walk to its end (real uvicorn and SQLite catalog, headless
Chromium; the recorder is the in-test link): after Stop it says "Saved. Computing the results…" while
the trial is recorded or processing, and leaves it for the trial's end state: done, done with warnings
(saying so) or failed (saying so). The worker's state changes are made in the catalog as a worker makes
them (the states' compare-and-set)."""

import pytest
from gaitcap.services import catalog as cat

from .conftest import signed_in_page

ENDS = {"done": ({}, "Ready for the next walk. Enter the patient ID"),
        "done_with_warnings": ({}, "carry data-quality warnings"),
        "failed": ({"error": "triangulation: no camera pair saw the patient"}, "Processing of the last walk failed")}


def _status(page) -> str:
    return page.inner_text("#record-status")


@pytest.mark.parametrize("end", list(ENDS))
def test_the_status_line_leaves_computing_for_the_end_state(server, end):
    srv, client, _, settings = server
    fields, words = ENDS[end]
    db = cat.open_catalog(settings.catalog_url)
    try:
        with signed_in_page(srv.url, timeout_ms=15_000) as page:
            page.fill("#subject", "P0007")
            page.once("dialog", lambda d: d.accept())  # the rig check's question (one in-test camera is slow)
            page.click("#start")
            page.wait_for_function("() => document.querySelector('#record-status').textContent.includes('Recording')")
            page.click("#stop")
            page.wait_for_function("() => document.querySelector('#record-status').textContent"
                                   ".startsWith('Saved. Computing the results')")
            tid = client.get("/trials").json()[0]["id"]
            cat.set_state(db, tid, "processing")
            page.wait_for_timeout(500)  # several status updates: still computing
            assert _status(page).startswith("Saved. Computing the results"), _status(page)
            cat.set_state(db, tid, end, **fields)
            page.wait_for_function(f"() => document.querySelector('#record-status').textContent.includes({words!r})")
            assert "Computing" not in _status(page)
            if end == "failed":
                assert fields["error"] in page.inner_text("#results-stage")
    finally:
        db.close()
