"""The clinical report: the PDF's text (patient, date, session, clinical fields, every parameter with
both sides, normal range and z-score, the previous visit, sources), the parameters JSON, patients with
their history over visits, trial corrections and voiding (audited)."""

import io
import json
import time

import numpy as np
import pytest
from gaitcap.acquisition.fileio import atomic_write_text
from gaitcap.services import catalog as cat
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.processing.outputs import steps_of, summary_of
from gaitcap.services.reports.content import PARAMETERS


@pytest.fixture(scope="module")
def gait_reports():
    """Gait reports of the synthetic walker at three speeds (three visits), 10 s each."""
    from gaitcap.reconstruction.gait import analyze_gait
    from gaitcap.reconstruction.skeletons import get_skeleton
    from gaitcap.simulator.params import WalkParams
    from gaitcap.simulator.path import Room, plan_walk
    from gaitcap.simulator.walker import simulate_body

    names, times, out = list(get_skeleton("halpe26").joint_names), np.arange(300) / 30.0, []
    for step_mm in (550.0, 600.0, 650.0):
        params = WalkParams(step_length_mm=step_mm)
        out.append(analyze_gait(simulate_body(plan_walk(params, 10.0, Room(), seed=0), params, times), times, names))
    return out


def _trial_with(server, report, *, subject: str, session: str) -> str:
    _, client, _, settings = server
    tid = client.post("/trials", json={"subject_id": subject, "session": session}).json()["id"]
    client.post(f"/trials/{tid}/stop")
    atomic_write_text(trial_files(settings.data_dir, tid).stage_file("refined", "gait_json"), report.to_json(indent=2))
    db = cat.open_catalog(settings.catalog_url)
    cat.store_result(db, trial_id=tid, stage="refined", method="implicit_fit", steps=steps_of(report),
                     summary=summary_of(report), quality={}, report={"warnings": list(report.warnings)})
    db.close()
    return tid


def test_report_pdf_text_has_patient_date_both_sides_norms_and_history(server, gait_reports):
    from pypdf import PdfReader

    _, client, _, _ = server
    first = _trial_with(server, gait_reports[0], subject="p0042", session="visit-1")
    tid = _trial_with(server, gait_reports[2], subject="P0042", session="visit-2")
    assert client.put("/patients/p0042", json={"sex": "female", "birth_year": 1960}).status_code == 200
    r = client.post(f"/trials/{tid}/correct", json={"operator": "alice", "walking_aid": "cane",
                                                     "footwear": "own shoes", "reason": "entered after the walk"})
    assert r.status_code == 200 and r.json()["changed"]["walking_aid"] == {"old": "", "new": "cane"}
    _, _, _, settings = server
    kin = trial_files(settings.data_dir, tid).stage_file("refined", "kinematics_json")
    kin.parent.mkdir(parents=True, exist_ok=True)
    kin.write_text(json.dumps({"key_values": {side: {"knee_peak_flexion_swing_deg": {"mean": value, "sd": 2.0, "n": 4}}
                                              for side, value in (("left", 61.25), ("right", 48.5))}}))
    pdf = client.get(f"/trials/{tid}/report.pdf")
    assert pdf.status_code == 200 and pdf.headers["content-type"] == "application/pdf"
    reader = PdfReader(io.BytesIO(pdf.content))
    assert 1 <= len(reader.pages) <= 3
    text = " ".join(" ".join(page.extract_text().split()) for page in reader.pages)
    trial = client.get(f"/trials/{tid}").json()
    day = time.strftime("%Y-%m-%d", time.gmtime(trial["started_at"]))
    for needle in ("P0042", day, "visit-2", tid, "cane", "own shoes", "alice", "Left", "Right", "SI %",
                   "Knee peak flexion in swing (flexion +) 61.2 ± 2.0 (n=4) 48.5 ± 2.0 (n=4)",
                   "Normal (95 %)", "Bohannon", "Signature", f"trial {first}", "Previous"):
        assert needle in text, needle
    for p in PARAMETERS.values():
        assert f"{p.label} ({p.unit})" in text, p.label
    js = client.get(f"/trials/{tid}/parameters").json()
    speed = next(p for p in js["parameters"] if p["name"] == "gait_speed_m_s")
    step = next(p for p in js["parameters"] if p["name"] == "step_length_mm")
    assert js["age"] == time.gmtime(trial["started_at"]).tm_year - 1960
    # under 70 the gait speed rows' SDs are not checked (Bohannon 1997): the mean only, as a percentage
    assert speed["normal_range"] is None and speed["z"] is None and js["gait_speed_reference"]["z"] is None
    assert step["left"] == pytest.approx(650.0, abs=5) and step["right"] == pytest.approx(650.0, abs=5)
    assert step["previous"] == pytest.approx(550.0, abs=5) and js["previous_trial"] == first
    assert step["normal_range"] is None and step["norm_source"] is None  # no step-length norm under 70 years
    g = client.get(f"/trials/{tid}/gait").json()
    assert g["sides"]["step_length_mm"]["left"]["mean"] == pytest.approx(650.0, abs=5)
    assert g["sides"]["step_time_s"]["right"]["n"] >= 2 and "symmetry_index_pct" in g["sides"]["step_time_s"]
    assert any("not used as steps" in w for w in g["analysis_warnings"])


def test_history_over_three_visits_shows_the_trend_and_leaves_void_out(server, gait_reports):
    _, client, _, _ = server
    ids = [_trial_with(server, rep, subject="P7", session=f"visit-{i + 1}") for i, rep in enumerate(gait_reports)]
    wrong = _trial_with(server, gait_reports[0], subject="P8", session="visit-1")
    r = client.post(f"/trials/{wrong}/correct", json={"subject_id": "p7", "session": "visit-3", "reason": " "})
    assert r.status_code == 422 and "reason" in r.json()["detail"]  # a correction says why
    r = client.post(f"/trials/{wrong}/correct", json={"subject_id": "p7", "session": "visit-3", "reason": "typo"})
    assert r.json()["changed"]["subject_id"] == {"old": "P8", "new": "P7"}
    assert client.post(f"/trials/{wrong}/mark-void", json={"reason": "walked with the wrong shoes"}).status_code == 200
    assert client.post(f"/trials/{wrong}/mark-void", json={"reason": "again and again"}).status_code == 409
    h = client.get("/patients/p7").json()
    assert h["id"] == "P7" and [t["id"] for t in h["history"]] == ids + [wrong]
    steps = [t["values"]["step_length_mm"] for t in h["history"] if not t["voided"]]
    assert steps == sorted(steps) and steps[-1] - steps[0] == pytest.approx(100.0, abs=10)
    assert h["history"][-1]["voided"] and h["history"][-1]["void_reason"] == "walked with the wrong shoes"
    listed = {t["id"]: t for t in client.get("/trials", params={"subject_id": "P7"}).json()}
    assert listed[wrong]["void_reason"] == "walked with the wrong shoes" and listed[wrong]["voided"]
    assert not listed[ids[0]]["voided"] and listed[ids[0]]["void_reason"] == ""
    assert h["history"][0]["normal_ranges"] == {}  # sex and birth year not recorded: no band
    client.put("/patients/P7", json={"sex": "male", "birth_year": time.gmtime().tm_year - 76})
    ranges = client.get("/patients/P7").json()["history"][0]["normal_ranges"]
    # Hollman 2011, men 75-79 (the shipped CSV): 1.22 +- 0.15 m/s, 106 +- 10 steps/min, 680 +- 70 mm
    assert ranges == {"gait_speed_m_s": pytest.approx([1.22 - 1.96 * 0.15, 1.22 + 1.96 * 0.15]),
                      "cadence_steps_min": pytest.approx([106 - 19.6, 106 + 19.6]),
                      "step_length_mm": pytest.approx([680 - 1.96 * 70, 680 + 1.96 * 70])}
    actions = {e["action"]: e["detail"] for e in client.get("/audit", params={"trial_id": wrong}).json()}
    assert "P8" in actions["correct"] and actions["mark void"] == "walked with the wrong shoes"
    pdf = client.get(f"/trials/{wrong}/report.pdf")
    from pypdf import PdfReader

    text = " ".join(p.extract_text() for p in PdfReader(io.BytesIO(pdf.content)).pages)
    assert "VOID: walked with the wrong shoes" in text and "Joint kinematics were not computed" in text
    assert [p["id"] for p in client.get("/patients", params={"prefix": "p"}).json()][0] == "P7"


def test_report_refusals_name_what_is_missing(server):
    _, client, _, _ = server
    tid = client.post("/trials", json={"subject_id": "P9"}).json()["id"]
    client.post(f"/trials/{tid}/stop")
    r = client.get(f"/trials/{tid}/report.pdf")
    assert r.status_code == 404 and "no results" in r.json()["detail"]
    assert client.get("/patients/NOBODY").status_code == 404
    r = client.put("/patients/P9", json={"sex": "other"})
    assert r.status_code == 422 and "sex" in r.json()["detail"]
    r = client.post(f"/trials/{tid}/mark-void", json={"reason": "no"})
    assert r.status_code == 422 and "reason" in r.json()["detail"]
