"""The clinic page in a real browser (Debian's Chromium, headless, driven by Playwright) against the whole
stack running as real processes: sign in, Start, walk, Stop, see preliminary then refined metrics."""

import time

import pytest

from tests.stack_helpers import TOKEN, running_stack

ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--disable-sync", "--no-first-run"]


@pytest.fixture(scope="module")
def stack(tmp_path_factory):
    with running_stack(tmp_path_factory.mktemp("browser")) as s:
        yield s


@pytest.fixture
def page(tmp_path):
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=ARGS)
        pg = browser.new_page(viewport={"width": 1280, "height": 1100})
        pg.set_default_timeout(20_000)
        try:
            yield pg
        finally:
            pg.screenshot(path=str(tmp_path / "last.png"), full_page=True)
            browser.close()


def test_sign_in_asks_for_the_access_code(stack, page):
    page.goto(stack.cfg.url + "/")
    page.wait_for_selector("#login:not([hidden])")
    page.fill("#token-input", "wrong-code-123")
    page.click("#login-form button")
    page.wait_for_selector("#login-error:not([hidden])")
    assert "not valid" in page.inner_text("#login-error")
    page.fill("#token-input", TOKEN)
    page.click("#login-form button")
    page.wait_for_selector("#app:not([hidden])")
    assert page.is_enabled("#start") and not page.is_enabled("#stop")


def test_start_walk_stop_shows_metrics(stack, page, tmp_path):
    page.goto(stack.page_url)
    page.wait_for_function("document.querySelectorAll('.camera.ok img[src^=\"blob:\"]').length >= 6",
                           timeout=60_000)
    assert "all working" in page.inner_text("#camera-summary")
    page.screenshot(path=str(tmp_path / "1-ready.png"), full_page=True)

    page.click("#start")  # no patient id: the page explains what is missing
    assert "patient ID" in page.inner_text("#error")
    page.fill("#subject", "P0042")
    page.click("#start")
    page.wait_for_function("document.querySelector('#record-status').textContent.includes('Recording patient P0042')")
    assert page.is_enabled("#stop") and not page.is_enabled("#start")
    page.wait_for_selector("#trials tr[data-trial] .state-recording")
    time.sleep(12)  # long enough to hold a straight pass of the simulated walk wherever it starts
    page.screenshot(path=str(tmp_path / "2-recording.png"), full_page=True)
    page.click("#stop")

    page.wait_for_selector("#results-summary[data-stage='preliminary'], #results-summary[data-stage='refined']",
                           timeout=60_000)
    page.screenshot(path=str(tmp_path / "3-preliminary.png"), full_page=True)
    page.wait_for_selector("#results-summary[data-stage='refined']", timeout=180_000)
    page.wait_for_function("document.querySelector('#report-plot').naturalWidth > 0")
    page.screenshot(path=str(tmp_path / "4-refined.png"), full_page=True)

    assert "Final results" in page.inner_text("#results-stage")
    cadence = page.inner_text("[data-metric='cadence_steps_per_min'] .value")
    assert 60 < float(cadence.split()[0]) < 160, cadence
    assert page.locator("#steps-table tbody tr").count() >= 2
    assert page.locator("#downloads a").count() == 6
    assert "Done" in page.inner_text("#trials tbody tr:first-child .state")
    assert page.is_enabled("#start")
