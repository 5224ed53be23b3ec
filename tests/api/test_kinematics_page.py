"""Joint angles where users see them: the page's curves per side over the normal band (a real browser),
the report's kinematics page (its text), and the band chosen by the patient's age over REST. The
kinematics.json is the one the worker writes, from the synthetic walker's angles measured on its
keypoints (no OpenSim needed: the fit itself is tested in tests/services/test_kinematics.py)."""

import io
import json

import numpy as np
import pytest
from gaitcap.acquisition.fileio import atomic_write_text
from gaitcap.services import catalog as cat
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.processing.outputs import steps_of, summary_of

from .conftest import sign_in_page
from .test_clinic_page import ARGS

HELD = {"pelvis_tilt": "held near 0 by the fit: no keypoint fixes it"}


@pytest.fixture(scope="module")
def walk():
    """12 s of the synthetic walker: its gait report and its kinematics.json content."""
    from gaitcap.reconstruction.gait import analyze_gait
    from gaitcap.reconstruction.kinematics.geometric import keypoint_angles
    from gaitcap.reconstruction.kinematics.report import kinematics_report
    from gaitcap.reconstruction.skeletons import get_skeleton
    from gaitcap.services.kinematics.files import norm_bands
    from gaitcap.simulator.params import WalkParams
    from gaitcap.simulator.path import Room, plan_walk
    from gaitcap.simulator.walker import simulate_body

    params, times = WalkParams(), np.arange(360) / 30.0
    points, names = simulate_body(plan_walk(params, 12.0, Room(), seed=0), params, times), get_skeleton("halpe26").joint_names
    gait = analyze_gait(points, times, list(names))
    a, zero = keypoint_angles(points, names), np.zeros(len(times))
    coords = {"pelvis_tilt": zero, "pelvis_list": zero, "pelvis_rotation": zero, "L5_S1_Flex_Ext": zero}
    for model, ours in (("hip_flexion", "hip_flexion"), ("hip_adduction", "hip_adduction"), ("knee_angle", "knee_flexion"),
                        ("ankle_angle", "ankle_dorsiflexion")):
        coords |= {f"{model}_{s[0]}": a[ours][s] for s in ("left", "right")}
    coords |= {f"hip_rotation_{s}": zero for s in "lr"}
    rep = kinematics_report(coords, times, gait.steps, norms=norm_bands(), held=HELD)
    return gait, {"available": True, **rep.to_dict()}


def _trial(server, walk, *, subject: str, kinematics: dict | None, birth_year: int | None = None) -> str:
    _, client, _, settings = server
    gait, _ = walk
    tid = client.post("/trials", json={"subject_id": subject, "session": "visit-1"}).json()["id"]
    client.post(f"/trials/{tid}/stop")
    files = trial_files(settings.data_dir, tid)
    atomic_write_text(files.stage_file("refined", "gait_json"), gait.to_json(indent=2))
    if kinematics is not None:
        path = files.stage_file("refined", "kinematics_json")
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(kinematics))
    db = cat.open_catalog(settings.catalog_url)
    cat.store_result(db, trial_id=tid, stage="refined", method="implicit_fit", steps=steps_of(gait),
                     summary=summary_of(gait), quality={})
    db.close()
    if birth_year:
        client.put(f"/patients/{subject}", json={"sex": "female", "birth_year": birth_year})
    return tid


def test_rest_band_follows_the_patients_age(server, walk):
    from gaitcap.services.kinematics.files import norms_for_age

    _, client, _, _ = server
    _, kin = walk
    for subject, born in (("A1", 1986), ("C1", None)):
        tid = _trial(server, walk, subject=subject, kinematics=kin, birth_year=born)
        body = client.get(f"/trials/{tid}/kinematics").json()
        age = client.get(f"/trials/{tid}/parameters").json()["age"]
        expected = norms_for_age(age).to_dict()
        assert body["norms"]["population"] == expected["population"] and body["norms"]["source"] == expected["source"]
        assert set(body["norms"]["bands"]) == set(expected["bands"])
        assert ("years" in body["norms"]["population"]) == (born is not None)  # the age it was chosen for
    adult = _trial(server, walk, subject="A5", kinematics=kin, birth_year=1986)
    bands = client.get(f"/trials/{adult}/kinematics").json()["norms"]["bands"]
    csv = client.get(f"/trials/{adult}/kinematics", params={"format": "csv"})
    rows = [line.split(",") for line in csv.text.splitlines()]
    assert csv.headers["content-type"].startswith("text/csv") and len(rows) == 102
    for name in ("knee_flexion", "hip_adduction"):  # the CSV's band columns are the patient's band
        assert (f"{name}_norm_mean_deg" in rows[0]) == (name in bands)
        if name in bands:
            col = rows[0].index(f"{name}_norm_mean_deg")
            assert [float(r[col]) for r in rows[1:]] == pytest.approx(bands[name]["mean_deg"], abs=0.006)
    png = client.get(f"/trials/{adult}/kinematics", params={"format": "png"})
    assert png.headers["content-type"] == "image/png" and png.content[:8] == b"\x89PNG\r\n\x1a\n"
    knee = body["curves"]["knee_flexion"]["left"]
    assert knee["n_cycles"] >= 3 and 40.0 < max(v for v in knee["mean_deg"] if v is not None) < 80.0
    assert "pelvis_tilt" not in body["curves"] and body["not_measured"] == HELD


def test_report_has_a_kinematics_page_with_curves_band_source_and_key_values(server, walk):
    from gaitcap.services.kinematics.files import norms_for_age
    from pypdf import PdfReader

    _, client, _, _ = server
    _, kin = walk
    tid = _trial(server, walk, subject="A2", kinematics=kin, birth_year=1986)
    reader = PdfReader(io.BytesIO(client.get(f"/trials/{tid}/report.pdf").content))
    pages = [" ".join(p.extract_text().split()) for p in reader.pages]
    page = next(p for p in pages if "Joint kinematics (mean +- SD per side" in p)  # beside the heel traces
    norms = norms_for_age(client.get(f"/trials/{tid}/parameters").json()["age"])
    assert f"normal mean +- 1 SD for {norms.population}" in page and norms.source.split(":")[0] in page
    assert "Pelvis tilt: not measured (held near 0" in page
    left = kin["key_values"]["left"]["knee_peak_flexion_swing_deg"]
    assert f"Knee peak flexion in swing (flexion +) {left['mean']:.1f} ± {left['sd']:.1f} (n={left['n']})" in page
    assert "No reference: the zero of this angle is not validated (" in page and "hip flexion: pelvic tilt" in page
    kv = client.get(f"/trials/{tid}/kinematics").json()["key_value_norms"]  # ranges of motion: whatever the zero
    for name in ("ankle_rom_deg", "hip_flexion_rom_deg"):
        assert f"{kv[name]['label']} " in page and f"at least {kv[name]['lower_limit_deg']:.1f}" in page, name
    assert "Hip flexion / extension" not in page and "Hip flexion: band not drawn: the zero of this angle" in page
    assert len(reader.pages[pages.index(page)].images) == 1  # the curves figure (no heel-trace plot stored)
    assert len(reader.pages) == 2


def test_page_draws_the_curves_per_side_over_the_band_or_says_why_not(server, walk):
    from gaitcap.services.kinematics.files import norms_for_age
    from playwright.sync_api import sync_playwright

    srv, client, _, _ = server
    _, kin = walk
    tid = _trial(server, walk, subject="A3", kinematics=kin, birth_year=1986)
    none = _trial(server, walk, subject="A4", kinematics={"available": False,
                                                          "reason": "the 'opensim' package is not installed"})
    ageless = _trial(server, walk, subject="A6", kinematics=kin)  # no birth year: no band, not the children's
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=ARGS)
        page = browser.new_page(viewport={"width": 1280, "height": 900})
        page.set_default_timeout(30_000)
        sign_in_page(page, srv.url)
        page.click(f"#trials tr[data-trial='{tid}'] .view")
        page.wait_for_selector("#kinematics-charts figure[data-variable='knee_flexion'][data-side='right'] .uplot")
        assert page.locator("#kinematics-charts .uplot").count() == 2 * len(kin["curves"])
        assert page.locator("#kinematics-charts figure[data-variable='pelvis_tilt']").count() == 0
        # a band under a curve only where the table compares the angle with it: not hip and ankle (their zero)
        band = lambda var, state: page.locator(f"#kinematics-charts figure[data-variable='{var}'][data-band='{state}']").count()  # noqa: E731
        assert band("knee_flexion", "drawn") == 2 and band("hip_flexion", "none") == band("ankle_dorsiflexion", "none") == 2
        notes = page.inner_text("#kinematics-notes")
        norms = norms_for_age(client.get(f"/trials/{tid}/parameters").json()["age"])
        assert norms.population in notes and norms.source in notes and "Pelvic tilt (anterior +): not measured" in notes
        from gaitcap.reconstruction.kinematics.key_norms import key_norms

        row = page.inner_text("#kinematics-keys tr[data-key='knee_peak_flexion_swing_deg']")
        assert f"{kin['key_values']['right']['knee_peak_flexion_swing_deg']['mean']:.1f} ±" in row
        # each key value against the band like a spatiotemporal parameter: its normal range and a flag outside it
        kv_norms = client.get(f"/trials/{tid}/kinematics").json()["key_value_norms"]
        for name, side_values in (("knee_flexion_initial_contact_deg", kin["key_values"]),
                                  ("knee_peak_flexion_swing_deg", kin["key_values"])):
            lo, hi = kv_norms[name]["normal_range_deg"]
            text = page.inner_text(f"#kinematics-keys tr[data-key='{name}']")
            # the server's texts, of the band's own range (not of the API's floats rounded to 2 decimals)
            band = key_norms(norms.to_dict()["bands"])[name].band()
            said = [f"{x:.1f}".lstrip("-") if float(f"{x:.1f}") == 0 else f"{x:.1f}" for x in band]
            assert kv_norms[name]["shown"]["normal_range"] == said and f"{said[0]}–{said[1]}" in text, text
            flagged = [s for s in ("left", "right") if not lo <= side_values[s][name]["mean"] <= hi]
            assert text.count("outside") == len(flagged), (name, text)
        assert kv_norms["knee_flexion_rom_deg"]["normal_range_deg"] is None  # a range of motion: no SD in a band
        # hip flexion's zero is not validated (pelvic tilt not measured): shown, never judged
        hip = page.inner_text("#kinematics-keys tr[data-key='hip_peak_flexion_deg']")
        assert "no reference: the zero of this angle is not validated" in hip and "outside" not in hip
        assert "Hip flexion / extension: band not drawn: the zero of this angle is not validated" in notes
        hip_rom = page.inner_text("#kinematics-keys tr[data-key='hip_flexion_rom_deg']")  # a range: judged
        assert f"at least {kv_norms['hip_flexion_rom_deg']['lower_limit_deg']:.1f}" in hip_rom
        assert kv_norms["hip_peak_flexion_deg"]["normal_range_deg"] is None
        profile = client.get(f"/trials/{tid}/kinematics").json()["gait_profile"]  # Baker 2009, on what it can
        assert profile["overall_gps_deg"] > 0 and "knee_flexion" in profile["variables"]
        assert "pelvis_tilt" in profile["not_included"] and "foot_progression" in profile["not_included"]
        page.set_viewport_size({"width": 390, "height": 844})  # a phone: one panel a row, nothing wider than it
        page.wait_for_timeout(300)
        assert page.evaluate("document.documentElement.scrollWidth") <= 390
        assert max(page.eval_on_selector_all("#kinematics-charts .uplot", "els => els.map(e => e.getBoundingClientRect().right)")) <= 390
        page.click(f"#trials tr[data-trial='{ageless}'] .view")
        page.wait_for_function("() => document.querySelector('#kinematics-notes').textContent.includes('no reference for this patient')")
        assert "No normal band: no reference for this patient: the patient's age is not recorded" in page.inner_text("#kinematics-notes")
        assert page.locator("#kinematics-charts figure[data-band='drawn']").count() == 0
        assert page.locator("#kinematics-charts figure[data-band='none'] .uplot").count() == 2 * len(kin["curves"])
        assert "no reference for this patient" in page.inner_text("#kinematics-keys tr[data-key='knee_flexion_initial_contact_deg']")
        page.click(f"#trials tr[data-trial='{none}'] .view")
        page.wait_for_function("() => document.querySelector('#kinematics-status').textContent.includes('opensim')")
        assert "Kinematics unavailable" in page.inner_text("#kinematics-status")
        assert page.locator("#kinematics-charts .uplot").count() == 0
        browser.close()
