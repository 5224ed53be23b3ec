"""One story on the page, the printed page and the PDF (real uvicorn and SQLite catalog, headless Chromium;
the cameras and recorder are the in-test link), at 1280, 768 and 390 px:

- a "Start refused" box goes once the cameras work again (a clinician's view of the rig check:
  tests/api/test_rig_check_page.py);
- the status line follows the stages (saved, preliminary, refined, done), never left on "Computing";
- the page shows the analysis's notes and step count as the PDF says them; the step table shows every
  column at 1280 px;
- a void trial printed from the page says VOID on every printed page, and its charts (drawn for a wider
  screen) fit an A4 page; the PDF report is at most 2 pages and about 100 kB, with or without sex and
  age, void or not, with joint-angle curves and a dozen warnings, and says the patient's sex and age;
- a blank correction reason is answered about the reason, never with the patient-ID rule."""

import contextlib
import io
import json
import time

import numpy as np
import pytest
from gaitcap.acquisition.fileio import atomic_write_text
from gaitcap.services import catalog as cat
from gaitcap.services.live.protocols import CameraHealth
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.processing.outputs import steps_of, summary_of

from .conftest import BROWSER_ARGS, sign_in_page
from .test_clinic_page import _fits
from .test_report_findings import _kinematics_of

WIDTHS = ((1280, 900), (768, 1024), (390, 844))
A4_CONTENT_PX = 705  # A4 (210 mm) less the print margins of style.css (12 mm a side) at 96 px per inch
PDF_MAX_BYTES = 150 * 1024


# the charts drawn 1200 px wide (uPlot commits a size in a microtask; no resize of the page runs in
# between), then what of the results sticks out to the right of a page ``w`` px wide
STICKING_OUT = """async (w) => {
  for (const c of charts) c.setSize({ width: 1200, height: c.height });
  for (let i = 0; i < 5; i++) await Promise.resolve();
  if (!charts.every((c) => c.width === 1200)) return ["the charts were not drawn 1200 px wide"];
  return [...document.querySelectorAll('#results *')].filter(e => e.getClientRects().length
    && e.getBoundingClientRect().right > w + 1).slice(0, 6)
    .map(e => `${e.tagName}#${e.id}.${e.className} ${Math.round(e.getBoundingClientRect().right)}`);
}"""


@contextlib.contextmanager
def browser_page(url: str, user: str = "alice", width: int = 1280, height: int = 900):
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=BROWSER_ARGS)
        try:
            page = browser.new_page(viewport={"width": width, "height": height}, timezone_id="UTC")
            page.set_default_timeout(20_000)
            page.on("dialog", lambda d: d.accept("shoes left on" if d.type == "prompt" else None))
            sign_in_page(page, url, user)
            yield page
        finally:
            browser.close()


@pytest.fixture(scope="module")
def walk():
    """The synthetic walker, 12 s: keypoints, times, joint names, its gait report and joint kinematics."""
    from gaitcap.reconstruction.gait import analyze_gait
    from gaitcap.reconstruction.skeletons import get_skeleton
    from gaitcap.simulator.params import WalkParams
    from gaitcap.simulator.path import Room, plan_walk
    from gaitcap.simulator.walker import simulate_body

    names, times, params = list(get_skeleton("halpe26").joint_names), np.arange(360) / 30.0, WalkParams()
    points = simulate_body(plan_walk(params, 12.0, Room(), seed=0), params, times)
    report = analyze_gait(points, times, names)
    return points, times, names, report, _kinematics_of(report, times, points, names)


def _store(settings, db, tid: str, stage: str, walk, *, figures: bool = True) -> None:
    from gaitcap.services.processing.report_plot import heel_traces_png

    points, times, names, report, kinematics = walk
    files = trial_files(settings.data_dir, tid)
    atomic_write_text(files.stage_file(stage, "gait_json"), report.to_json(indent=2))
    np.savez(files.stage_file(stage, "trajectory_npz"), points_mm=points, times_s=times, joint_names=np.array(names))
    if figures:
        files.stage_file(stage, "report_png").write_bytes(heel_traces_png(report, points, times, names))
        files.stage_file(stage, "kinematics_json").parent.mkdir(parents=True, exist_ok=True)
        files.stage_file(stage, "kinematics_json").write_text(json.dumps(kinematics))
    cat.store_result(db, trial_id=tid, stage=stage, method="implicit_fit" if stage == "refined" else "robust_triangulation",
                     steps=steps_of(report), summary=summary_of(report), quality={},
                     report={"warnings": list(report.warnings)})


def _status(page) -> str:
    return page.inner_text("#record-status")


def _wait_status(page, words: str) -> None:
    page.wait_for_function("w => document.querySelector('#record-status').textContent.includes(w)", arg=words)


def rule(x, d: int) -> str:
    """The one rounding rule, again here: the stored value correctly rounded, never "-0"."""
    text = f"{x:.{d}f}"
    return text.lstrip("-") if float(text) == 0 else text


def _key_values_as_the_pdf(page, client, tid: str, pdf_text: str) -> None:
    """The page's key joint-angle values are the server's texts (never rounded again in the browser) and
    read as the PDF's table reads them: each side's mean +- SD (n), the normal range, "outside" where the
    PDF marks "!"."""
    kin = client.get(f"/trials/{tid}/kinematics").json()
    said, norms = kin["key_values_shown"], kin["key_value_norms"]
    page.wait_for_selector("#kinematics-keys tr[data-key]")
    checked = 0
    for name in kin["key_values"]["left"]:
        stats = {s: kin["key_values"][s][name] for s in ("left", "right")}
        if not any(v["n"] for v in stats.values()):
            continue
        row = page.inner_text(f"#kinematics-keys tr[data-key='{name}']")
        cells = []
        for side, v in stats.items():
            t = said[side][name]
            assert t["mean"] == rule(v["mean"], 1) and t["sd"] == (rule(v["sd"], 1) if v["sd"] is not None else None)
            cells.append(f"{t['mean']} ± {t['sd']} (n={v['n']})" if t["sd"] else f"{t['mean']} (n={v['n']})")
        assert all(c in row for c in cells), (name, cells, row)
        marked = " ".join(c + (" !" if said[s][name]["outside"] else "") for c, s in zip(cells, stats, strict=True))
        assert marked in pdf_text, (name, marked)  # the PDF's row: the same texts, "!" where the page says "outside"
        assert row.count("outside") == sum(bool(said[s][name]["outside"]) for s in stats), (name, row)
        shown_norm = norms[name]["shown"]
        if shown_norm["normal_range"]:
            lo, hi = shown_norm["normal_range"]
            assert f"{lo}–{hi}" in row and f"{lo} to {hi}" in pdf_text, (name, row)
        checked += 1
    assert checked >= 5, checked


def _history_as_the_server_shows_it(page, client, tid: str, patient: str) -> None:
    """The history table and the trend captions show the server's texts: the visit's numbers as
    ``GET /trials/{id}/gait`` rounds them, and the normal range of the last visit as the norm table's band
    for the patient's sex and age, rounded by the same rule."""
    from gaitcap.services.reports.content import NORM_UNITS, PARAMETERS
    from gaitcap.services.reports.norms import load_norms

    page.evaluate("id => showHistory(id)", patient)
    page.wait_for_selector(f"#history-table tr[data-trial='{tid}']")
    page.wait_for_selector("#trends .trend .uplot")
    gait, person = client.get(f"/trials/{tid}/gait").json(), client.get(f"/patients/{patient}").json()
    row = page.eval_on_selector_all(f"#history-table tr[data-trial='{tid}'] td", "c => c.map(x => x.textContent)")
    columns = (("gait_speed_m_per_s", 2), ("cadence_steps_per_min", 1), ("step_length_mm", 0),
               ("step_length_asymmetry_pct", 1))
    assert row[3:7] == [rule(gait["summary"][key]["mean"], d) for key, d in columns], row
    assert row[3:7] == [gait["shown"][key]["mean"] for key, _ in columns], row
    visit = next(t for t in person["history"] if t["id"] == tid)
    names = ("gait_speed_m_s", "cadence_steps_min", "step_length_mm", "step_length_symmetry_index_pct")
    assert row[3:7] == [visit["shown"]["values"][n] for n in names], (row, visit["shown"])
    age = client.get(f"/trials/{tid}/parameters").json()["age"]
    norms = load_norms(units=NORM_UNITS)
    caps = dict(page.eval_on_selector_all("#trends figure", "f => f.map(x => [x.dataset.parameter, x.querySelector('figcaption').textContent])"))
    for name in ("gait_speed_m_s", "step_length_mm", "cadence_steps_min"):
        lo, hi = (rule(x, PARAMETERS[name].decimals) for x in norms.find(name, sex="female", age=age).band())
        assert f"(at the last visit {lo}–{hi} {PARAMETERS[name].unit})" in caps[name], (name, caps[name])


def test_a_refused_start_clears_when_the_cameras_return(server):
    srv, _, link, _ = server
    working = list(link.camera_list)
    link.camera_list = [CameraHealth(c.name, 0.0, False, "no images", 9.0) for c in working]
    with browser_page(srv.url, width=390, height=844) as page:
        page.fill("#subject", "P0501")
        page.click("#start")
        page.wait_for_selector("#error:not([hidden])")
        assert page.inner_text("#error").startswith("Start refused: no camera is delivering images")
        page.wait_for_timeout(500)  # several status updates with the cameras still down: the box stays
        assert page.is_visible("#error")
        link.camera_list = [CameraHealth(c.name, 30.0, True, "ok", 0.01) for c in working]  # they return
        page.wait_for_selector("#error", state="hidden")
        assert "cameras are working again" in _status(page) and page.is_enabled("#start")
        _fits(page, 390, "phone")


def test_the_status_line_follows_the_stages_to_the_end(server, walk):
    srv, client, _, settings = server
    db = cat.open_catalog(settings.catalog_url)
    try:
        with browser_page(srv.url, width=768, height=1024) as page:
            page.fill("#subject", "P0502")
            page.click("#start")
            _wait_status(page, "Recording patient P0502")
            page.click("#stop")
            _wait_status(page, "Saved. Computing the results")
            tid = client.get("/trials").json()[0]["id"]
            cat.set_state(db, tid, "processing")
            _store(settings, db, tid, "preliminary", walk, figures=False)
            _wait_status(page, "Preliminary results below. Refining the 3D reconstruction")
            cat.set_progress(db, tid, stage="refined", progress=0.6)
            _store(settings, db, tid, "refined", walk, figures=False)
            cat.set_progress(db, tid, stage="kinematics", progress=0.8)
            _wait_status(page, "Refined results below. Finishing the trial (kinematics)")
            page.wait_for_timeout(400)  # the status line keeps the stage's words (not "Computing")
            assert "Computing" not in _status(page)
            cat.set_state(db, tid, "done")
            _wait_status(page, "Ready for the next walk")
    finally:
        db.close()


def test_notes_steps_print_and_pdf_tell_one_story_at_every_width(server, walk, tmp_path):
    from pypdf import PdfReader

    srv, client, _, settings = server
    db = cat.open_catalog(settings.catalog_url)
    try:
        earlier = client.post("/trials", json={"subject_id": "P0503", "session": "visit-1"}).json()["id"]
        client.post(f"/trials/{earlier}/stop")
        _store(settings, db, earlier, "refined", walk)
        time.sleep(0.01)
        tid = client.post("/trials", json={"subject_id": "P0503", "session": "visit-2"}).json()["id"]
        client.post(f"/trials/{tid}/stop")
        _store(settings, db, tid, "refined", walk)
        warnings = [f"Camera cam{i:02d} lost {i} frames of 600 (check its cable and network)" for i in range(12)]
        cat.set_quality(db, tid, "processing", {"warnings": warnings})
    finally:
        db.close()

    def report() -> tuple[list[str], int]:
        pdf = client.get(f"/trials/{tid}/report.pdf", timeout=120).content  # a loaded machine renders slowly
        return [" ".join(p.extract_text().split()) for p in PdfReader(io.BytesIO(pdf)).pages], len(pdf)

    pages, size = report()  # the patient's sex and age not recorded, a dozen warnings, curves, a previous visit
    assert len(pages) <= 2 and size <= PDF_MAX_BYTES, (len(pages), size)
    assert "patient P0503 (sex not recorded, age not recorded)" in pages[-1]  # on every page's header
    client.put("/patients/P0503", json={"sex": "female", "birth_year": time.gmtime().tm_year - 74})
    pages, size = report()
    assert len(pages) <= 2 and size <= PDF_MAX_BYTES, (len(pages), size)
    assert all("patient P0503 (female, 74 years)" in p for p in pages)

    gait = client.get(f"/trials/{tid}/gait").json()
    notes = gait["analysis_warnings"]
    assert notes, "the walk's analysis has notes (contacts not used as steps)"
    with browser_page(srv.url) as page:
        page.evaluate("id => follow(id)", tid)
        page.wait_for_selector("#results-notes:not([hidden])")
        page.wait_for_selector("#steps-table tbody tr")
        for width, height in WIDTHS:
            page.set_viewport_size({"width": width, "height": height})
            shown = page.eval_on_selector_all("#results-notes li", "l => l.map(x => x.textContent)")
            assert [n for n in shown if n in notes] == notes, (width, shown)  # the notes the PDF has
            assert page.is_visible("#results-notes li")
            count = page.inner_text("#results-steps-count")
            assert count.endswith("analysed.") and count in " ".join(pages), (width, count)
            _fits(page, width, ("results", width))
        page.set_viewport_size({"width": 1280, "height": 900})  # the step table: every column in view
        wrap = "#steps-table"
        columns = page.eval_on_selector_all(f"{wrap} thead th", "t => t.length")
        assert columns == 1 + len([k for k, v in gait["steps"][0].items() if not isinstance(v, (dict, list))]), columns
        assert page.eval_on_selector(wrap, "t => { const w = t.closest('.table-wrap'); return w.scrollWidth <= w.clientWidth + 1; }"), (
            page.eval_on_selector(wrap, "t => [t.closest('.table-wrap').scrollWidth, t.closest('.table-wrap').clientWidth]"))
        last = page.locator(f"{wrap} thead th").last.bounding_box()
        assert last["x"] + last["width"] <= 1280, last
        _key_values_as_the_pdf(page, client, tid, " ".join(pages))
        _history_as_the_server_shows_it(page, client, tid, "P0503")

        page.click("#correct-box summary")  # a blank reason: refused about the reason, not the patient ID
        page.fill("#fix-reason", "   ")
        page.click("#correct-form button[type=submit]")
        assert "give the reason" in page.inner_text("#correct-status")
        assert "Patient ID" not in page.inner_text("#correct-status")
        r = client.post(f"/trials/{tid}/correct", json={"session": "visit-2", "reason": "  "})
        assert r.status_code == 422 and r.json()["detail"] == "reason: must not be blank: say why", r.json()
        r = client.post(f"/trials/{tid}/correct", json={"session": "visit 2", "reason": "typo"})  # an id: the id rule
        assert r.status_code == 422 and "letters, digits" in r.json()["detail"]

        page.click("#void-button")
        page.wait_for_function("() => document.querySelector('#results-patient').textContent.includes('VOID: shoes left on')")
        page.wait_for_selector("#heel-chart .uplot")
        pdf = PdfReader(io.BytesIO(page.pdf(format="A4")))  # the page printed: VOID on every sheet
        printed = [" ".join(p.extract_text().split()) for p in pdf.pages]
        assert len(printed) >= 2 and all("VOID - not for clinical use: shoes left on" in p for p in printed), [
            p[:120] for p in printed]
        # printed on A4 while the charts are still drawn for the screen: nothing sticks out of the sheet
        page.emulate_media(media="print")
        page.set_viewport_size({"width": A4_CONTENT_PX, "height": 1000})
        page.wait_for_timeout(300)  # the page's own resize has run: now the charts are made 1200 px wide again
        wide = page.evaluate(STICKING_OUT, A4_CONTENT_PX)
        assert wide == [], wide
        assert page.is_visible("#heel-chart canvas") and page.is_visible("#steps-table")
        page.emulate_media(media="screen")

    pages, size = report()  # void, with sex and age: still 2 pages
    assert len(pages) <= 2 and size <= PDF_MAX_BYTES and all("VOID" in p for p in pages), (len(pages), size)
