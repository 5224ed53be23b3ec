"""The clinic page in a real browser (Chromium via Playwright) against a real uvicorn and catalog:
nothing before sign-in, phone / tablet / desktop widths, readable field messages, keyboard-only use of
the history, both sides against the norms on the results card, the trial list updated in place."""

import calendar

import numpy as np
import pytest
from gaitcap.acquisition.fileio import atomic_write_text
from gaitcap.services import catalog as cat
from gaitcap.services.catalog.models import Trial
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.processing.outputs import steps_of, summary_of
from sqlalchemy import update

from .conftest import sign_in_page

ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run"]
TRENDS = ("gait_speed_m_s", "step_length_mm", "cadence_steps_min", "step_length_symmetry_index_pct")
OVERFLOWING = """() => {  // what sticks out of the page (not what scrolls inside a box of its own)
  const clipped = (e) => { for (let a = e.parentElement; a; a = a.parentElement)
    if (/(auto|scroll|hidden|clip)/.test(getComputedStyle(a).overflowX)) return true; return false; };
  return [...document.querySelectorAll('body *')].filter(e => e.getBoundingClientRect().right > innerWidth + 1
    && !clipped(e)).slice(0, 8).map(e => `${e.tagName}#${e.id}.${e.className} ${Math.round(e.getBoundingClientRect().right)}`);
}"""
def _fits(page, width_px: int, what) -> None:
    """The page is no wider than ``width_px`` once the charts have followed a resize (uPlot resizes on the
    next animation frames, within 2 s here); else the elements sticking out are named."""
    try:
        page.wait_for_function(f"document.documentElement.scrollWidth <= {width_px}", timeout=2000)
    except Exception:  # playwright's TimeoutError: say what sticks out
        raise AssertionError((what, page.evaluate("document.documentElement.scrollWidth"),
                              page.evaluate(OVERFLOWING))) from None


WIDTHS = {"phone": (390, 844), "tablet": (820, 1180), "desktop": (1280, 900)}
# when the three visits took place (UTC, the browser's time zone here): two weeks apart, then twice on one day
VISIT_TIMES = ((2026, 11, 10, 9, 30), (2026, 11, 24, 10, 0), (2026, 11, 24, 14, 30))


@pytest.fixture(scope="module")
def walk_report():
    from gaitcap.reconstruction.gait import analyze_gait
    from gaitcap.reconstruction.skeletons import get_skeleton
    from gaitcap.simulator.params import WalkParams
    from gaitcap.simulator.path import Room, plan_walk
    from gaitcap.simulator.walker import simulate_body

    params, times = WalkParams(), np.arange(300) / 30.0
    points, names = simulate_body(plan_walk(params, 10.0, Room(), seed=0), params, times), get_skeleton("halpe26").joint_names
    return points, times, names, analyze_gait(points, times, list(names))


@pytest.fixture
def visits(server, walk_report):
    """Three visits of P0042 (at VISIT_TIMES) with refined results, the patient's sex and birth year recorded."""
    _, client, _, settings = server
    db, ids = cat.open_catalog(settings.catalog_url), []
    points, times, names, report = walk_report
    for i in range(3):
        tid = client.post("/trials", json={"subject_id": "P0042", "session": f"visit-{i + 1}"}).json()["id"]
        client.post(f"/trials/{tid}/stop")
        files = trial_files(settings.data_dir, tid)
        atomic_write_text(files.stage_file("refined", "gait_json"), report.to_json(indent=2))
        np.savez(files.stage_file("refined", "trajectory_npz"), points_mm=points, times_s=times, joint_names=np.array(names))
        cat.store_result(db, trial_id=tid, stage="refined", method="implicit_fit", steps=steps_of(report),
                         summary=summary_of(report), quality={})
        started_s = calendar.timegm((*VISIT_TIMES[i], 0, 0, 0, 0))
        with db.session() as s:
            s.execute(update(Trial).where(Trial.id == tid).values(started_at=started_s, stopped_at=started_s + 20))
        ids.append(tid)
    db.close()
    client.put("/patients/P0042", json={"sex": "male", "birth_year": 1956})
    return ids


@pytest.fixture
def browser_page():
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=ARGS)
        page = browser.new_page(viewport={"width": 390, "height": 844}, timezone_id="UTC")
        page.set_default_timeout(30_000)  # a loaded 2-core machine answers slowly
        yield page
        browser.close()


CONTRAST = """([sel, prop]) => {
  // WCAG contrast ratio of an element's colour against the first opaque background behind it
  const rgb = (c) => c.match(/[\\d.]+/g).map(Number);
  const lum = ([r, g, b]) => [r, g, b].map((v) => { v /= 255; return v <= 0.03928 ? v / 12.92 : ((v + 0.055) / 1.055) ** 2.4; })
    .reduce((a, v, i) => a + v * [0.2126, 0.7152, 0.0722][i], 0);
  let el = document.querySelector(sel), fg = rgb(getComputedStyle(el)[prop]), bg;
  while (el) { const c = rgb(getComputedStyle(el).backgroundColor); if (c.length === 3 || c[3] > 0.9) { bg = c; break; } el = el.parentElement; }
  const [a, b] = [lum(fg), lum(bg || [255, 255, 255])].sort((x, y) => y - x);
  return (a + 0.05) / (b + 0.05);
}"""


TICKS = "() => trendCharts.map(c => c.axes[0]._values)"  # the x tick labels uPlot drew
AXIS_OF = """async (times) => {  // the tick labels of a trend-sized chart of visits at these UNIX times (s)
  const box = document.createElement("div"), axis = visitAxis(times);
  box.style.width = "400px"; document.body.append(box);
  const u = new uPlot({ width: 400, height: 190, series: [{}, {}], scales: { x: axis.scale }, axes: [axis.axis, {}] },
                      [times, times.map(() => 1)], box);
  await new Promise((drawn) => requestAnimationFrame(() => requestAnimationFrame(drawn)));
  const labels = u.axes[0]._values; u.destroy(); box.remove();
  return labels;
}"""


def _tab_to(page, selector: str, limit: int = 60) -> None:
    for _ in range(limit):
        page.keyboard.press("Tab")
        if page.evaluate(f"document.activeElement === document.querySelector({selector!r})"):
            return
    raise AssertionError(f"{selector} is not reachable with Tab")


def test_clinic_page_at_phone_tablet_desktop_keyboard_only(server, visits, browser_page):
    srv, *_ = server
    page = browser_page
    page.goto(srv.url + "/")
    page.wait_for_selector("#login:not([hidden])")
    assert not page.is_visible("#app") and not page.is_visible("#start")  # nothing before sign-in
    _, client, _, _ = server
    long = client.post("/trials", json={"subject_id": "Q" * 32, "session": "s" * 64}).json()["id"]
    client.post(f"/trials/{long}/stop")
    sign_in_page(page, srv.url)
    page.wait_for_selector(f"#trials tr[data-trial='{long}']")  # the longest ids in the list
    for name, (w, h) in WIDTHS.items():
        page.set_viewport_size({"width": w, "height": h})
        _fits(page, w, name)
        for button in ("#start", "#stop"):
            box = page.locator(button).bounding_box()
            assert box["x"] >= 0 and box["x"] + box["width"] <= w, (name, button, box)
    page.set_viewport_size({"width": 390, "height": 844})
    assert page.evaluate(CONTRAST, ["#subject", "borderTopColor"]) >= 3.0  # WCAG 2.1 non-text contrast
    for sel in ("#subject-hint", "footer", "h2 small"):
        assert page.evaluate(CONTRAST, [sel, "color"]) >= 4.5, sel  # WCAG AA text
    page.fill("#subject", "P" * 80)
    assert "use at most 32" in page.inner_text("#subject-error")
    assert page.input_value("#subject") == "P" * 80  # never cut silently
    page.fill("#session", "Visit 1")
    assert "no spaces" in page.inner_text("#session-error") and "visit-1" in page.inner_text("#session-error")
    page.fill("#subject", "P" + "0" * 63)
    _fits(page, 390, "phone")

    page.locator("body").focus()  # a new patient's sex and birth year, by keyboard, audited
    _tab_to(page, "#patient-input")
    page.keyboard.type("p0777")
    page.keyboard.press("Enter")
    page.wait_for_function("() => document.querySelector('#patient-summary').textContent.includes('New patient P0777')")
    _tab_to(page, "#patient-sex")
    page.keyboard.type("female")
    _tab_to(page, "#patient-birth-year")
    page.keyboard.type("52")
    page.keyboard.press("Enter")
    assert "four digits" in page.inner_text("#patient-details-status")
    assert page.get_attribute("#patient-birth-year", "aria-invalid") == "true"
    page.keyboard.press("Control+a")
    page.keyboard.type("1952")
    page.keyboard.press("Enter")
    page.wait_for_function("() => document.querySelector('#patient-details-status').textContent.includes('Saved (audited)')")
    assert {k: client.get("/patients/P0777").json()[k] for k in ("sex", "birth_year")} == {"sex": "female", "birth_year": 1952}
    assert any(e["action"] == "patient edit" and "P0777" in e["detail"] for e in client.get("/audit").json())
    _fits(page, 390, "phone")
    _tab_to(page, "#patient-input")
    page.keyboard.press("Control+a")
    page.keyboard.type("p0042")
    page.keyboard.press("Enter")
    page.wait_for_selector("#history-table tbody tr:nth-child(3)")
    page.wait_for_selector("#trends .trend .uplot")
    assert page.eval_on_selector_all("#trends .trend", "f => f.map(x => x.dataset.parameter)") == list(TRENDS)
    points = page.evaluate("() => trendCharts.map(c => c.data[1].filter(v => v != null).length)")
    assert points == [3, 3, 3, 3], points
    # the date axis: a date per visit as far as they fit (the newest first), the time only on a shared day
    assert page.evaluate(TICKS) == [["10 Nov 2026", "24 Nov 2026 14:30"]] * 4
    for visits_at, labels in (  # any spacing: minutes, days, years apart
            (((2026, 11, 24, 10, 0), (2026, 11, 24, 10, 5)), ["24 Nov 2026 10:00", "24 Nov 2026 10:05"]),
            (((2026, 11, 23, 10, 0), (2026, 11, 24, 10, 0)), ["23 Nov 2026", "24 Nov 2026"]),
            (((2024, 11, 10, 8, 0), (2025, 11, 3, 8, 0), (2026, 11, 24, 23, 59)), ["10 Nov 2024", "3 Nov 2025", "24 Nov 2026"])):
        times = [calendar.timegm((*t, 0, 0, 0, 0)) for t in visits_at]
        assert page.evaluate(AXIS_OF, times) == labels
    caps = page.eval_on_selector_all("#trends figcaption", "c => c.map(x => x.textContent)")
    assert [c.split(" per visit, by visit date;")[0] for c in caps] == [  # each names its parameter and unit
        "Gait speed (m/s)", "Step length (mm)", "Cadence (steps/min)", "Step length symmetry index (%)"], caps
    # a man of 70 (Hollman 2011, men 70-74): gait speed 1.17 +- 0.16 m/s, step length 690 +- 80 mm, cadence
    # 102 +- 8 steps/min; the band is mean +- 1.96 SD at each visit; the symmetry index has no reference
    bands = page.evaluate("() => trendCharts.map(c => c.data.length === 5 ? [c.data[4][0], c.data[3][0]] : null)")
    for band, (mean, sd) in zip(bands, ((1.17, 0.16), (690, 80), (102, 8)), strict=False):
        assert band == pytest.approx([mean - 1.96 * sd, mean + 1.96 * sd], rel=1e-3), bands
    assert bands[3] is None and "no reference" in page.inner_text("#trends [data-parameter$='symmetry_index_pct']")
    _tab_to(page, "#history-table tbody tr:nth-child(1) .cmp")  # two visits side by side, by keyboard
    page.keyboard.press("Space")
    _tab_to(page, "#history-table tbody tr:nth-child(3) .cmp")
    page.keyboard.press("Space")
    page.wait_for_selector("#compare:not([hidden])")
    head = page.inner_text("#compare-table thead")  # each visit by session, date and time (two on one day differ)
    assert "visit-1, 10 Nov 2026 09:30" in head and "visit-3, 24 Nov 2026 14:30" in head, head
    step = page.inner_text("#compare-table tbody tr:nth-child(3)").split("\t")
    assert step[0] == "Step length (mm)" and step[1:3] == ["650", "650"] and step[-3:] == ["0", "0", "0"], step  # per side, never "+0"
    # each trend keeps a least y range (a change of 0.01 m/s does not fill the chart like a fall)
    spans = page.evaluate("() => trendCharts.map(c => c.scales.y.max - c.scales.y.min)")
    assert spans[0] >= 0.5 and spans[1] >= 200 and spans[2] >= 30, spans
    _tab_to(page, "#history-table tbody tr:nth-child(2) .cmp")  # a third tick: said, not silently hidden
    page.keyboard.press("Space")
    page.wait_for_selector("#compare-note:not([hidden])")
    assert "tick exactly two" in page.inner_text("#compare-note") and page.is_hidden("#compare")
    page.keyboard.press("Space")
    page.wait_for_selector("#compare:not([hidden])")
    assert page.is_hidden("#compare-note")
    assert "Patient P0042" in page.inner_text("#patient-summary")

    page.wait_for_selector("#trials tbody tr[data-trial] .view")
    first = page.locator("#trials tbody tr[data-trial]").first
    first.evaluate("row => { window.firstRow = row; }")
    page.wait_for_timeout(600)  # several status updates later the row is the same element
    assert first.evaluate("row => row === window.firstRow")
    _tab_to(page, "#trials tbody tr[data-trial] .view")
    page.keyboard.press("Enter")
    page.wait_for_selector("#sides-wrap:not([hidden])")
    # the results come into view with the focus on their heading (they lie far above the list on a phone)
    assert page.evaluate("document.activeElement.id") == "results-heading"
    assert abs(page.eval_on_selector("#results", "e => e.getBoundingClientRect().top")) < 5
    assert "Patient P0042" in page.inner_text("#results-patient") and "visit-3" in page.inner_text("#results-patient")
    widths = page.eval_on_selector_all("#sides-table tr[data-parameter='step_time_s'] .bar",
                                       "bars => bars.map(b => b.getBoundingClientRect().width)")
    assert len(widths) == 2 and max(widths) > 0  # per-side bars to one scale
    step = page.eval_on_selector_all("#sides-table tr[data-parameter='step_length_mm'] td", "c => c.map(x => x.textContent)")
    assert step[1:3] == ["650", "650"], step  # left, right (mm)
    # a phone shows each parameter as a card of labelled values: nothing off to the side, even inside the table
    assert page.eval_on_selector("#sides-wrap", "w => w.scrollWidth <= w.clientWidth && w.clientWidth <= 390")
    assert page.eval_on_selector("#sides-table tr[data-parameter='step_length_mm'] td[data-label='z']",
                                 "c => getComputedStyle(c, '::before').content").startswith('"z: "')
    sides = page.get_by_role("table", name="Parameters by side with the normal range")
    assert sides.get_by_role("row", name="Step length (mm)").first.get_by_role("cell").count() == 9  # still a table
    speed = page.inner_text("#sides-table tr[data-parameter='gait_speed_m_s']")
    assert "no reference" not in speed  # a 70-year-old man: gait speed has a normal range
    assert page.get_attribute("#report-pdf", "href").endswith("/report.pdf")
    page.wait_for_selector("#heel-chart .uplot")  # interactive figures (uPlot from the package)
    legend = page.inner_text("#heel-chart .u-legend")
    assert "left heel (mm)" in legend and "right heel strike" in legend and "toe off" in legend
    assert page.locator("#foot-chart .uplot").count() == 1 and not page.is_visible("#report-plot")
    _fits(page, 390, "phone")
    page.emulate_media(media="print")  # the print stylesheet: the results only, no cameras, buttons or lists
    assert page.is_visible("#sides-table") and page.is_visible("#results-patient")
    assert not any(page.is_visible(s) for s in ("#cameras-card", "#record", "#trials-card", "header", "#print"))
    assert page.is_visible("#heel-chart .uplot") and page.is_visible("#foot-chart .uplot")  # the charts print too
    assert page.eval_on_selector("#steps-table", "t => t.closest('.table-wrap').scrollHeight <= t.closest('.table-wrap').clientHeight + 1")
    page.emulate_media(media="screen")
    assert page.get_attribute("#record-status", "aria-live") == "polite"
    assert page.locator("#record-timer[aria-live]").count() == 0

    page.click("#correct-box summary")
    assert page.input_value("#fix-subject") == "P0042"
    page.fill("#fix-aid", "cane")
    page.click("#correct-form button[type=submit]")  # no reason: refused, the field says why
    assert "give the reason" in page.inner_text("#correct-status")
    assert page.evaluate("document.activeElement.id") == "fix-reason"
    page.fill("#fix-reason", "entered after the walk")
    page.click("#correct-form button[type=submit]")
    page.wait_for_function("() => document.querySelector('#correct-status').textContent.includes('walking aid changed')")
    asked = []
    page.once("dialog", lambda d: (asked.append(d.message), d.accept("walked with the wrong shoes")))
    page.click("#void-button")
    page.wait_for_function("() => document.querySelector('#results-patient').textContent.includes('VOID: walked with')")
    assert "At least 5 characters" in asked[0]  # the minimum is said before, not only when refused
    page.wait_for_timeout(400)  # several status updates later the header still says VOID (it once lost it)
    assert "VOID: walked with the wrong shoes" in page.inner_text("#results-patient")
    struck = page.eval_on_selector("#sides-table tbody td[data-label='Mean']", "td => getComputedStyle(td).textDecorationLine")
    assert "line-through" in struck
    page.emulate_media(media="print")  # the printed page carries the void mark too
    assert "VOID" in page.evaluate("() => getComputedStyle(document.querySelector('#results'), '::before').content")
    page.emulate_media(media="screen")
    for name, (w, h) in WIDTHS.items():  # the void mark, the count of normal ranges and the findings at every width
        page.set_viewport_size({"width": w, "height": h})
        page.wait_for_timeout(300)  # status updates come and go: the header keeps VOID
        assert "VOID: walked with the wrong shoes" in page.inner_text("#results-patient"), name
        assert page.is_visible("#norm-summary") and "parameters have a normal range" in page.inner_text("#norm-summary"), name
        _fits(page, w, name)
    page.set_viewport_size({"width": 390, "height": 844})
    voided = page.locator(f"#trials tr.voided[data-trial='{visits[2]}']")  # marked in the trial list
    voided.wait_for()
    assert "Void: walked with the wrong shoes" in voided.inner_text()
    page.click("#patient-form button[type=submit]")  # the history again: the void visit is out of the trends
    page.wait_for_function("() => document.querySelector('#trend-note').textContent.includes('1 void trial(s) left out')")
    assert page.evaluate("() => trendCharts.map(c => c.data[1].length)") == [2, 2, 2, 2]
    assert page.evaluate(TICKS) == [["10 Nov 2026", "24 Nov 2026"]] * 4  # one visit a day: dates only
    assert "Void: walked with the wrong shoes" in page.inner_text(f"#history-table tr.voided[data-trial='{visits[2]}']")
    for w, h in ((390, 844), (768, 1024), (901, 900), (1280, 900)):  # both lists fit (901: the narrowest as
        # tables); their void notes are on screen
        page.set_viewport_size({"width": w, "height": h})
        _fits(page, w, w)
        for table in ("#trials", "#history-table"):
            assert page.eval_on_selector(table, "t => t.parentElement.scrollWidth <= t.parentElement.clientWidth"), (w, table)
            note = page.locator(f"{table} tr.voided .void-note").first
            note.scroll_into_view_if_needed()
            box = note.bounding_box()
            assert box["x"] >= 0 and box["x"] + box["width"] <= w and 0 <= box["y"] <= h - box["height"], (w, table, box)
            # to a screen reader still a table (cards or not): its headers, rows and cells, each cell named by
            # its content only (the label drawn before it on a card is the column header's job)
            grid = page.get_by_role("table").and_(page.locator(table))
            assert grid.count() == 1, (w, table)
            assert grid.get_by_role("columnheader", name="Session", exact=True).count() == 1, (w, table)
            assert grid.get_by_role("row").count() == 1 + page.locator(f"{table} tbody tr").count(), (w, table)
            assert grid.get_by_role("cell", name="visit-2", exact=True).count() == 1, (w, table)
        lines = page.eval_on_selector_all("#history-table a", "links => links.map(a => a.getClientRects().length)")
        assert lines == [1, 1, 1], (w, lines)  # "Report (PDF)" on one line, never broken letter by letter
    page.set_viewport_size({"width": 390, "height": 844})
    page.check("#trend-void")  # unless asked for, then drawn as a grey ring
    assert page.evaluate("() => trendCharts.map(c => c.data[2].filter(v => v != null).length)") == [1, 1, 1, 1]

    page.click("#clinical-fields summary")
    page.fill("#subject", "p0042")
    page.fill("#session", "visit-4")
    page.fill("#walking-aid", "walker")
    page.once("dialog", lambda d: d.accept())  # the rig check's confirmation (one simulated camera is slow)
    page.click("#start")
    page.wait_for_function("() => document.querySelector('#record-status').textContent.includes('Recording patient P0042')")
    tid = client.get("/trials").json()[0]["id"]
    for _ in range(50):
        entries = [e for e in client.get("/audit", params={"trial_id": tid}).json() if e["action"] == "correct"]
        if entries:
            break
        page.wait_for_timeout(100)
    assert "'walker'" in entries[0]["detail"] and "operator: '' -> 'alice'" in entries[0]["detail"]
    client.post(f"/trials/{tid}/stop")  # from elsewhere (another tab): the page's Recording line goes at once
    page.wait_for_function("() => document.querySelector('#record-status').textContent.includes('recording was stopped')",
                           timeout=3000)
    assert not page.is_disabled("#start") and page.is_disabled("#stop")
