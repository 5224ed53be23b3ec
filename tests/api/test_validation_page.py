"""The page's validation section (a real browser): shown with the trial's ``gaitcap validate`` result,
hidden for a trial without one; the trial's PDF report prints the same rows, rounded the same way."""

import io
import json

import numpy as np
import pytest
from gaitcap.acquisition.fileio import atomic_write_text
from gaitcap.services import catalog as cat
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.processing.outputs import steps_of, summary_of
from gaitcap.services.validation.names import FILES, TRIAL_FOLDER

from .conftest import sign_in_page
from .test_clinic_page import ARGS

RESULT = {"reference": "/lab/FunctionalWalk.c3d", "reference_kind": "C3D", "icc_form": "ICC(A,1): two-way random",
          "alignment": {"lag_s": 0.2473, "residual_mm": 15.4},
          "events": [{"side": "left", "kind": "heel_strike", "n": 3, "signed_median_ms": -47.0,
                      "signed_median_frames": -1.41, "missed": 0, "extra": 0}],
          "parameters": {"step_length_mm": {"all": {"n": 5, "bias": 2.7, "loa_low": -8.1, "loa_high": 13.5, "icc": 0.98}}},
          "angles": [{"side": "right", "variable": "knee_flexion", "n": 97, "rmse_deg": 4.7, "offset_deg": 3.6,
                      "rmse_after_offset_deg": 2.9, "r": 0.989}],
          "not_compared": ["reference: joint angles of the hip rotation"]}


@pytest.fixture(scope="module")
def gait():
    from gaitcap.reconstruction.gait import analyze_gait
    from gaitcap.reconstruction.skeletons import get_skeleton
    from gaitcap.simulator.params import WalkParams
    from gaitcap.simulator.path import Room, plan_walk
    from gaitcap.simulator.walker import simulate_body

    params, times = WalkParams(), np.arange(180) / 30.0
    points = simulate_body(plan_walk(params, 6.0, Room(), seed=0), params, times)
    return analyze_gait(points, times, list(get_skeleton("halpe26").joint_names))


def _trial(server, gait, subject, result):
    _, client, _, settings = server
    tid = client.post("/trials", json={"subject_id": subject}).json()["id"]
    client.post(f"/trials/{tid}/stop")
    files = trial_files(settings.data_dir, tid)
    atomic_write_text(files.stage_file("preliminary", "gait_json"), gait.to_json(indent=2))
    if result is not None:
        (files.root / TRIAL_FOLDER).mkdir()
        (files.root / TRIAL_FOLDER / FILES["json"]).write_text(json.dumps(result))
    db = cat.open_catalog(settings.catalog_url)
    cat.store_result(db, trial_id=tid, stage="preliminary", method="robust_triangulation", steps=steps_of(gait),
                     summary=summary_of(gait), quality={})
    db.close()
    return tid


def test_page_shows_the_validation_or_nothing(server, gait):
    from playwright.sync_api import sync_playwright

    srv = server[0]
    tid = _trial(server, gait, "V1", RESULT)
    none = _trial(server, gait, "V2", None)
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=ARGS)
        page = browser.new_page(viewport={"width": 1280, "height": 900})
        page.set_default_timeout(30_000)
        sign_in_page(page, srv.url)
        page.click(f"#trials tr[data-trial='{tid}'] .view")
        page.wait_for_selector("#validation:not([hidden])")
        assert "lag +0.247 s, residual 15.4 mm" in page.inner_text("#validation-status")
        table = page.inner_text("#validation-table")
        assert "left heel strike" in table and "-47 ms (-1.41 frames)" in table and "ICC 0.98" in table
        assert "right knee flexion" in table and "offset +3.6 deg, after offset 2.9 deg" in table
        assert "bias +2.70 (95 % limits of agreement -8.10 to +13.50)" in table
        page_rows = [" ".join(r.split()) for r in page.locator("#validation-table tbody tr").all_inner_texts()]
        assert "Not compared: reference: joint angles" in page.inner_text("#validation-notes")
        assert page.get_attribute("#validation-links a", "href").endswith(f"/trials/{tid}/validation/pdf")
        page.click(f"#trials tr[data-trial='{none}'] .view")
        page.wait_for_function("() => document.querySelector('#results-summary').dataset.stage === 'preliminary'")
        page.wait_for_timeout(500)
        assert page.locator("#validation").is_hidden()
        browser.close()
    _pdf_has_the_pages_rows(server, tid, none, page_rows)


def _pdf_text(client, tid: str) -> str:
    from pypdf import PdfReader

    pdf = client.get(f"/trials/{tid}/report.pdf")
    assert pdf.status_code == 200, pdf.text
    reader = PdfReader(io.BytesIO(pdf.content))
    assert len(reader.pages) <= 2
    return " ".join(" ".join(page.extract_text().split()) for page in reader.pages)


def _pdf_has_the_pages_rows(server, tid: str, none: str, page_rows: list[str]) -> None:
    """Every row the page showed is printed in the trial's report, with the same texts."""
    _, client, _, _ = server
    shown = client.get(f"/trials/{tid}/validation").json()["shown"]
    assert len(page_rows) == len(shown["rows"]) == 3, (page_rows, shown)
    text = _pdf_text(client, tid)
    assert "Agreement with the lab's reference" in text and shown["alignment"] in text
    for row, on_page in zip(shown["rows"], page_rows, strict=True):
        for part in (row["what"], row["difference"], row["agreement"]):
            assert part in on_page and part in text, (part, on_page)
    assert "Not compared: reference: joint angles of the hip rotation" in text
    assert "Agreement with the lab's reference" not in _pdf_text(client, none)
