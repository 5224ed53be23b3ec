"""The test of the whole for "one story everywhere": every statement the clinic page (in Chromium) and the
PDF report make about a trial, its numbers (left, right, mean, SD, symmetry index, the summary tiles),
its norms (normal range, z-score), its findings, its analysis notes and the change since another visit,
is derived again here from ``GET /trials/{id}/gait`` (and the norm table for the patient's age and sex),
written with the one rounding rule, and must agree: over three simulated patients (a woman of 74 with a
step-length asymmetry, a man of 80, a patient with no recorded sex or birth year), two visits each (one
patient's both on the same day), in both stages (preliminary only, then refined)."""

import calendar
import contextlib
import io
import math
import re
import time

import numpy as np
import pytest
from gaitcap.acquisition.fileio import atomic_write_text
from gaitcap.services import catalog as cat
from gaitcap.services.catalog.models import Trial
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.processing.outputs import steps_of, summary_of
from gaitcap.services.reports.content import NORM_UNITS, PARAMETERS
from gaitcap.services.reports.norms import load_norms
from sqlalchemy import update

from .conftest import BROWSER_ARGS, sign_in_page

YEAR = time.gmtime().tm_year
# patient -> (sex, birth year, the two visits' walks (WalkParams fields), the two visits' start (UTC))
PATIENTS = {
    "PA01": ("female", YEAR - 74, ({"step_asymmetry": 0.1}, {"step_asymmetry": 0.04, "step_length_mm": 620.0}),
             ((2026, 11, 3, 9, 15), (2026, 11, 24, 11, 40))),
    "PB02": ("male", YEAR - 80, ({"step_length_mm": 500.0, "cadence_spm": 95.0}, {"step_length_mm": 540.0}),
             ((2026, 11, 24, 10, 0), (2026, 11, 24, 14, 30))),  # two visits on one day
    "PC03": ("", None, ({"step_width_mm": 140.0}, {"stance_asymmetry": 0.03}),
             ((2026, 10, 1, 8, 0), (2026, 11, 2, 16, 5))),
}
SUMMARY_DECIMALS = {"gait_speed_m_per_s": 2, "cadence_steps_per_min": 1, "step_length_asymmetry_pct": 1,
                    "steps_count": 0}


def rule(x, d: int) -> str:
    """The rounding rule the statements must follow: the stored value, correctly rounded, no "-0"."""
    if x is None or not math.isfinite(x):
        return "–"
    text = f"{x:.{d}f}"
    return text.lstrip("-") if float(text) == 0 else text


@pytest.fixture(scope="module")
def walks():
    """Per patient and visit, the preliminary and the refined gait report (the preliminary one of a
    noisier keypoint set), 10 s of the synthetic walker."""
    from gaitcap.reconstruction.gait import analyze_gait
    from gaitcap.reconstruction.skeletons import get_skeleton
    from gaitcap.simulator.params import WalkParams
    from gaitcap.simulator.path import Room, plan_walk
    from gaitcap.simulator.walker import simulate_body

    names, times, out = list(get_skeleton("halpe26").joint_names), np.arange(300) / 30.0, {}
    for subject, (_, _, params, _) in PATIENTS.items():
        for visit, fields in enumerate(params):
            p = WalkParams(**fields)
            points = simulate_body(plan_walk(p, 10.0, Room(), seed=visit), p, times)
            noisy = points + np.random.default_rng(visit).normal(0.0, 4.0, points.shape)
            out[subject, visit] = {"preliminary": analyze_gait(noisy, times, names),
                                   "refined": analyze_gait(points, times, names)}
    return out


def _store(settings, db, tid: str, stage: str, report) -> None:
    atomic_write_text(trial_files(settings.data_dir, tid).stage_file(stage, "gait_json"), report.to_json(indent=2))
    cat.store_result(db, trial_id=tid, stage=stage, method="robust_triangulation" if stage == "preliminary"
                     else "implicit_fit", steps=steps_of(report), summary=summary_of(report), quality={},
                     report={"warnings": list(report.warnings)})


def _trials(server, db) -> dict:
    """(patient, visit) -> trial id, recorded at the patients' visit times, sex and birth year recorded."""
    _, client, _, _ = server
    ids = {}
    for subject, (sex, born, _, starts) in PATIENTS.items():
        for visit, start in enumerate(starts):
            tid = client.post("/trials", json={"subject_id": subject, "session": f"visit-{visit + 1}"}).json()["id"]
            client.post(f"/trials/{tid}/stop")
            t0 = calendar.timegm((*start, 0, 0, 0, 0))
            with db.session() as s:
                s.execute(update(Trial).where(Trial.id == tid).values(started_at=t0, stopped_at=t0 + 20))
            ids[subject, visit] = tid
        if sex:
            client.put(f"/patients/{subject}", json={"sex": sex, "birth_year": born})
    return ids


# ------------------------------------------------------------------ statements derived from GET /gait


def derived(client, tid: str, norms) -> dict:
    """What may be said of the trial, from ``GET /gait`` alone (and the norm table for the patient): per
    parameter the shown left, right, mean, SD, SI, normal range and z; the tiles; the analysis notes."""
    g = client.get(f"/trials/{tid}/gait").json()
    trial = client.get(f"/trials/{tid}").json()
    patient = client.get(f"/patients/{trial['subject_id']}").json()
    age = time.gmtime(trial["started_at"]).tm_year - patient["birth_year"] if patient["birth_year"] else None
    sides, summary = g["sides"], g["summary"]
    doubt = set(g["consistency"].get("parameters_in_doubt") or ())
    rows = {}
    for name, p in PARAMETERS.items():
        d = p.decimals
        if name in sides:
            s = sides[name]
            left, right, mean = (s[k]["mean"] if s.get(k) else None for k in ("left", "right", "all"))
            sd, si = (s.get("all") or {}).get("sd"), s.get("symmetry_index_pct")
        elif name == "cadence_steps_min":
            st = sides["step_time_s"]
            left, right = (60.0 / st[k]["mean"] for k in ("left", "right"))
            mean, sd, si = summary["cadence_steps_per_min"]["mean"], None, 100 * abs(left - right) / (0.5 * (left + right))
        else:
            left = right = sd = si = None
            mean = summary["gait_speed_m_per_s"]["mean"]
        norm = norms.find(name, sex=patient["sex"], age=age)
        band = norm.band() if norm is not None else None
        z = norm.z(mean) if norm is not None and mean is not None else None
        rows[name] = {"left": rule(left, d), "right": rule(right, d), "mean": rule(mean, d), "sd": rule(sd, d + 1),
                      "si": rule(si, 1), "range": (rule(band[0], d), rule(band[1], d)) if band else None,
                      "z": None if z is None else ("+" if float(rule(z, 1)) > 0 else "") + rule(z, 1),
                      "raw": {"mean": mean, "si": si, "z": z}, "in_doubt": name in doubt}
    tiles = {name: rule(m.get("mean"), SUMMARY_DECIMALS[name] if name in SUMMARY_DECIMALS
                 else PARAMETERS[name].decimals)
             for name, m in summary.items() if m.get("mean") is not None}
    return {"rows": rows, "tiles": tiles, "notes": g["analysis_warnings"], "stage": g["stage"], "gait": g}


def _finding_forms(name: str) -> tuple[re.Pattern, re.Pattern]:
    p = PARAMETERS[name]
    label, unit = re.escape(p.label), re.escape(p.unit)
    return (re.compile(rf"^{label} differs between sides: left (\S+), right (\S+) {unit} \(symmetry index (\S+) %\)\.$"),
            re.compile(rf"^{label} (\S+) {unit} is (below|above) the normal range for age and sex "
                       rf"\((-?[\d.]+)-(-?[\d.]+) {unit}\)\.$"))


def check_findings(findings: list[str], want: dict, where: str) -> None:
    """Each finding's numbers are the derived ones, and none is said beyond what they show: a side
    difference only over 10 % SI, outside the range only with |z| > 1.96, never on a parameter in doubt."""
    for said in findings:
        f = said.removeprefix("Preliminary: ")  # a preliminary finding may say so; a refined one never does
        assert f == said or want["stage"] == "preliminary", (where, said)
        read = False
        for name in PARAMETERS:
            sides, outside = _finding_forms(name)
            row = want["rows"][name]
            if m := sides.match(f):
                assert (m[1], m[2], m[3]) == (row["left"], row["right"], row["si"]), (where, f, row)
                assert row["raw"]["si"] > 10 and not row["in_doubt"], (where, f, row)
                read = True
            elif m := outside.match(f):
                assert m[1] == row["mean"] and (m[3], m[4]) == row["range"], (where, f, row)
                assert abs(row["raw"]["z"]) > 1.96 and (m[2] == "below") == (row["raw"]["z"] < 0), (where, f, row)
                assert not row["in_doubt"], (where, f, row)
                read = True
        assert read, (where, "a finding that no number of GET /gait states", f)


# ------------------------------------------------------------------ what the page and the PDF say

PAGE_ROWS = """() => Object.fromEntries([...document.querySelectorAll('#sides-table tr[data-parameter]')].map(tr =>
  [tr.dataset.parameter, [...tr.children].map(td => td.textContent.trim())]))"""
PAGE_SAYS = """() => ({
  tiles: Object.fromEntries([...document.querySelectorAll('#results-summary .metric')].map(m =>
    [m.dataset.metric, m.querySelector('.value').firstChild.textContent.trim()])),
  flags: [...document.querySelectorAll('#results-flags li')].map(li => li.textContent),
  notes: [...document.querySelectorAll('#results-notes li')].map(li => li.textContent),
  steps: document.querySelector('#results-steps-count').textContent,
  norm: document.querySelector('#norm-summary').textContent,
  stage: document.querySelector('#results-summary').dataset.stage })"""


def page_says(page, tid: str) -> dict:
    page.evaluate("id => follow(id)", tid)
    page.wait_for_function("id => state.followed === id && document.querySelector('#results-summary').dataset.stage"
                           " && !document.querySelector('#sides-wrap').hidden && document.querySelector('#results-patient')"
                           ".textContent.includes('session')", arg=tid)
    page.wait_for_function("() => !document.querySelector('#results-notes').hidden")
    rows = page.evaluate(PAGE_ROWS)
    return {**page.evaluate(PAGE_SAYS), "rows": rows}


def pdf_says(client, tid: str) -> dict:
    from pypdf import PdfReader

    pdf = client.get(f"/trials/{tid}/report.pdf", timeout=120)  # a loaded machine renders slowly
    assert pdf.status_code == 200
    pages = [p.extract_text() for p in PdfReader(io.BytesIO(pdf.content)).pages]
    lines = [ln.strip() for ln in pages[0].splitlines()]
    rows = {}
    for name, p in PARAMETERS.items():
        head = f"{p.label} ({p.unit}) "
        line = next(ln for ln in lines if ln.startswith(head))
        rows[name] = line[len(head):].replace("no reference", "no_reference").split()
    text = " ".join(" ".join(p.split()) for p in pages)
    findings = text.split("Findings to note", 1)[1].split("Heel traces", 1)[0]
    return {"rows": rows, "text": text, "pages": len(pages), "bytes": len(pdf.content), "findings": findings}


def _bare(text: str) -> str:
    """Without white space (a PDF's lines break anywhere)."""
    return re.sub(r"\s", "", text)


STATES = ("differs between sides:", "is below the normal range", "is above the normal range")


def _claims(text: str) -> int:
    return sum(_bare(text).count(_bare(s)) for s in STATES)


def _pdf_row(cells: list[str], has_previous: bool) -> dict:
    left, right, mean, sd, _cv, si = cells[:6]
    if cells[6] == "no_reference":
        rng, z, rest = None, None, cells[8:]
    else:
        m = re.match(r"^(-?[\d.]+)-(-?[\d.]+)$", cells[6])
        rng, z, rest = (m[1], m[2]), cells[7], cells[9:]
    return {"left": left, "right": right, "mean": mean, "sd": sd, "si": si, "range": rng, "z": z,
            "previous": rest[0] if has_previous else None}


def _dash(text: str) -> str:
    return "–" if text in ("-", "–") else text


def agree(want: dict, page: dict, pdf: dict, previous: dict | None, where: str) -> int:
    """Page, PDF and the derived statements agree; returns the number of statements compared."""
    n = 0
    assert page["stage"] == want["stage"], where
    for name, row in want["rows"].items():
        cells = page["rows"][name]
        on_page = {"left": cells[1], "right": cells[2], "mean": cells[3], "sd": cells[4], "si": cells[5], "z": cells[7]}
        for k in ("left", "right", "mean", "sd", "si"):
            assert _dash(on_page[k]) == row[k], (where, name, k, on_page[k], row[k])
        in_pdf = _pdf_row(pdf["rows"][name], previous is not None)
        for k in ("left", "right", "mean", "sd", "si"):
            assert _dash(in_pdf[k]) == row[k], (where, "pdf", name, k, in_pdf[k], row[k])
        if row["range"] is None:  # no normal range: none on the page (gait speed may say % of the mean), none in the PDF
            assert cells[6] == "no reference" or "% of the age-sex mean" in cells[6], (where, name, cells[6])
            assert in_pdf["range"] is None and _dash(on_page["z"]) == "–", (where, name, in_pdf)
        else:
            assert tuple(cells[6].split("–", 1)) == row["range"] == in_pdf["range"], (where, name, cells[6], in_pdf)
            assert on_page["z"] == row["z"] == in_pdf["z"], (where, name, on_page["z"], in_pdf["z"], row["z"])
        if previous is not None:
            assert _dash(in_pdf["previous"]) == previous["rows"][name]["mean"], (where, "previous", name)
        n += 7
    for name, value in want["tiles"].items():
        assert page["tiles"][name] == value, (where, "tile", name, page["tiles"][name], value)
        n += 1
    # the analysis's notes: those of GET /gait, in order, with any note on what was not said (a finding
    # withheld) whose numbers are the derived ones; the PDF says the same notes
    assert [n for n in page["notes"] if n in want["notes"]] == want["notes"], (where, page["notes"], want["notes"])
    for note in (n for n in page["notes"] if n not in want["notes"]):
        stated = [(name, m[1]) for name, p in PARAMETERS.items()
                  for m in re.finditer(rf"\b{re.escape(p.label)} (-?[\d.]+) {re.escape(p.unit)}\b", note)]
        assert all(value == want["rows"][name]["mean"] for name, value in stated), (where, note, stated)
    assert page["steps"] in pdf["text"], (where, page["steps"])
    if want["notes"]:
        notes = "Notes of the analysis: " + "; ".join(want["notes"]) + "."
        assert _bare(notes) in _bare(pdf["text"]), (where, notes)
    withheld = [n for n in page["notes"] if n not in want["notes"]]
    for note in withheld:  # said in the PDF too (beside its findings)
        assert _bare(note) in _bare(pdf["text"]), (where, note)
    assert page["norm"].split(" Gait speed ")[0] in pdf["text"], (where, page["norm"])
    for flag in page["flags"]:  # the page's findings are the PDF's, and the PDF makes no other
        assert _bare(flag) in _bare(pdf["findings"]), (where, flag)
    assert _claims(pdf["findings"]) - sum(_claims(n) for n in withheld) == len(page["flags"]), (where, pdf["findings"])
    check_findings(page["flags"], want, where)
    stated = want["gait"].get("findings")  # GET /gait states the stage's findings itself: the same sentences
    stated = stated if isinstance(stated, dict) else {"findings": stated}
    if isinstance(stated.get("findings"), list):
        assert page["flags"] == stated["findings"], (where, page["flags"], stated)
    if isinstance(stated.get("withheld"), list):
        assert [n for n in page["notes"] if n not in want["notes"]] == stated["withheld"], (where, stated)
    assert page["norm"].startswith(stated.get("norm_summary") or ""), (where, page["norm"], stated)
    assert pdf["pages"] <= 2, (where, pdf["pages"])
    return n + len(want["tiles"]) + len(page["flags"]) + len(want["notes"])


def compare_says(page, subject: str) -> dict:
    page.evaluate("id => showHistory(id)", subject)
    page.wait_for_selector("#history-table tbody tr:nth-child(2) .cmp:not([disabled])")
    for box in page.locator("#history-table .cmp").all():
        if not box.is_checked():
            box.check()
    page.wait_for_function("() => !document.querySelector('#compare').hidden && "
                           "document.querySelectorAll('#compare-table tbody tr').length > 0")
    head = page.eval_on_selector_all("#compare-table thead th.visit", "t => t.map(x => x.textContent)")
    rows = page.evaluate("""() => Object.fromEntries([...document.querySelectorAll('#compare-table tbody tr')].map(tr =>
      [tr.dataset.parameter, [...tr.children].map(td => td.textContent.trim())]))""")
    return {"head": head, "rows": rows}


def change(earlier: str, later: str, d: int) -> str:
    if "–" in (earlier, later):
        return "–"
    delta = float(later) - float(earlier)
    text = f"{delta:.{d}f}"
    return "0" if float(text) == 0 else ("+" if delta > 0 else "") + text


@contextlib.contextmanager
def utc_page(url: str, width: int = 1280, height: int = 900):
    """A signed-in headless Chromium page whose clock reads UTC (the PDF's time zone)."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=BROWSER_ARGS)
        try:
            page = browser.new_page(viewport={"width": width, "height": height}, timezone_id="UTC")
            page.set_default_timeout(20_000)
            sign_in_page(page, url)
            yield page
        finally:
            browser.close()


def test_every_statement_of_page_and_pdf_is_the_one_derived_from_get_gait(server, walks):
    srv, client, _, settings = server
    norms = load_norms(units=NORM_UNITS)
    db = cat.open_catalog(settings.catalog_url)
    compared = 0
    try:
        ids = _trials(server, db)
        with utc_page(srv.url) as page:
            for stage in ("preliminary", "refined"):
                for key, tid in ids.items():
                    _store(settings, db, tid, stage, walks[key][stage])
                for (subject, visit), tid in ids.items():
                    where = f"{subject} visit {visit + 1} {stage}"
                    want = derived(client, tid, norms)
                    assert want["stage"] == stage, where
                    previous = derived(client, ids[subject, 0], norms) if visit == 1 else None
                    compared += agree(want, page_says(page, tid), pdf_says(client, tid), previous, where)
                for subject, (_, _, _, starts) in PATIENTS.items():  # the change since the other visit
                    got = compare_says(page, subject)
                    first, second = (derived(client, ids[subject, v], norms) for v in (0, 1))
                    for head, start, visit in zip(got["head"], starts, (1, 2), strict=True):
                        d = time.strftime("%-d %b %Y %H:%M", time.gmtime(calendar.timegm((*start, 0, 0, 0, 0))))
                        assert head == f"visit-{visit}, {d}", (subject, head)  # by date and time of day
                    for name, p in PARAMETERS.items():
                        cells, a, b = got["rows"][name], first["rows"][name], second["rows"][name]
                        assert cells[1:7] == [a["left"], a["right"], a["mean"], b["left"], b["right"], b["mean"]], (subject, name, cells)
                        assert cells[7:] == [change(a[k], b[k], p.decimals) for k in ("left", "right", "mean")], (
                            subject, stage, name, cells)
                        compared += 9
    finally:
        db.close()
    assert compared > 1000, compared
