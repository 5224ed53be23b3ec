"""The report and the page's numbers say nothing false: findings only against a norm (with a count of the
parameters that had one), numbers that disagree shown as a data problem and never as a finding, a void
trial marked VOID on every page of its PDF, percentiles as ordinals."""

import copy
import io
import json
import time

import numpy as np
import pytest
from gaitcap.acquisition.fileio import atomic_write_text
from gaitcap.services import catalog as cat
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.processing.outputs import steps_of, summary_of
from gaitcap.services.reports.pdf import ordinal


@pytest.fixture(scope="module")
def walk():
    """The gait report of the synthetic walker, 10 s, as gait.json holds it."""
    from gaitcap.reconstruction.gait import analyze_gait
    from gaitcap.reconstruction.skeletons import get_skeleton
    from gaitcap.simulator.params import WalkParams
    from gaitcap.simulator.path import Room, plan_walk
    from gaitcap.simulator.walker import simulate_body

    names, times, params = list(get_skeleton("halpe26").joint_names), np.arange(300) / 30.0, WalkParams()
    return analyze_gait(simulate_body(plan_walk(params, 10.0, Room(), seed=0), params, times), times, names)


def _trial(server, report, gait: dict, *, subject: str, stored: dict | None = None) -> str:
    _, client, _, settings = server
    tid = client.post("/trials", json={"subject_id": subject, "session": "visit-1"}).json()["id"]
    client.post(f"/trials/{tid}/stop")
    atomic_write_text(trial_files(settings.data_dir, tid).stage_file("preliminary", "gait_json"), json.dumps(gait))
    db = cat.open_catalog(settings.catalog_url)
    cat.store_result(db, trial_id=tid, stage="preliminary", method="robust_triangulation", steps=steps_of(report),
                     summary=summary_of(report), quality={}, report={"warnings": [], **(stored or {})})
    db.close()
    return tid


def _pdf_pages(client, tid) -> list[str]:
    from pypdf import PdfReader

    pdf = client.get(f"/trials/{tid}/report.pdf")
    assert pdf.status_code == 200
    return [" ".join(p.extract_text().split()) for p in PdfReader(io.BytesIO(pdf.content)).pages]


def test_without_norms_nothing_is_called_normal_and_with_norms_the_count_is_given(server, walk):
    _, client, _, _ = server
    tid = _trial(server, walk, walk.to_dict(), subject="P100")
    js = client.get(f"/trials/{tid}/parameters").json()
    assert js["consistency"]["ok"] and js["data_problems"] == [] and not any(p["in_doubt"] for p in js["parameters"])
    measured = sum(p["mean"] is not None for p in js["parameters"])
    assert js["norm_summary"] == (f"No reference for this patient (sex and birth year not recorded): none of the "
                                  f"{measured} parameters has a normal range, no value is called normal or abnormal.")
    text = " ".join(_pdf_pages(client, tid))
    assert "no value is called normal or abnormal" in text and "No reference for this patient" in text
    assert "outside the normal range" not in text and "No parameter outside" not in text
    client.put("/patients/P100", json={"sex": "female", "birth_year": time.gmtime().tm_year - 74})
    js = client.get(f"/trials/{tid}/parameters").json()
    referenced = [p for p in js["parameters"] if p["normal_range"] is not None and p["mean"] is not None]
    outside = [p for p in referenced if abs(p["z"]) > 1.96]
    assert len(referenced) >= 6
    verdict = "none outside it" if not outside else f"{len(outside)} outside it"
    assert js["norm_summary"] == (f"{len(referenced)} of {measured} parameters have a normal range for age and sex; "
                                  f"{verdict}.")
    assert sum("normal range for age and sex (" in f for f in js["flags"]) == len(outside)
    assert js["norm_summary"] in " ".join(_pdf_pages(client, tid))


def test_numbers_that_disagree_are_a_data_problem_never_a_finding(server, walk):
    """The issue's visit 1: right single support 0.52 s (47.3 %) next to stance 61.6 % and double support
    24.4 %: the page and the report list a data problem, and make no side-difference finding of it."""
    _, client, _, _ = server
    gait = copy.deepcopy(walk.to_dict())
    params = gait["summary"]["parameters"]
    stride = params["stride_time_s"]["right"]["mean"]
    params["single_support_s"]["right"]["mean"] = 0.52
    params["single_support_pct"]["right"]["mean"] = 100 * 0.52 / stride
    si = 100 * abs(0.52 - params["single_support_s"]["left"]["mean"]) / (0.5 * (0.52 + params["single_support_s"]["left"]["mean"]))
    gait["summary"]["asymmetry_pct"]["single_support_s"] = si
    assert si > 10
    tid = _trial(server, walk, gait, subject="P101")
    js = client.get(f"/trials/{tid}/parameters").json()
    assert not js["consistency"]["ok"]
    doubt = {p["name"] for p in js["parameters"] if p["in_doubt"]}
    assert {"single_support_s", "single_support_pct", "stance_time_s"} <= doubt and "step_length_mm" not in doubt
    assert not [f for f in js["flags"] if f.startswith("Single support")]
    assert js["data_problems"] and all(p.startswith("Data problem, not a clinical finding:") for p in js["data_problems"])
    assert any("right mean" in p and "single support 0.520" in p for p in js["data_problems"])
    text = " ".join(_pdf_pages(client, tid))
    assert "Data problem, not a clinical finding" in text and "Single support differs between sides" not in text


def test_a_void_trial_says_void_on_every_pdf_page(server, walk):
    _, client, _, _ = server
    tid = _trial(server, walk, walk.to_dict(), subject="P102")
    assert client.post(f"/trials/{tid}/mark-void", json={"reason": "wrong patient walked"}).status_code == 200
    pages = _pdf_pages(client, tid)
    assert len(pages) >= 2
    assert all("VOID - not for clinical use: wrong patient walked" in p for p in pages)
    assert client.get(f"/trials/{tid}/parameters").json()["voided"] is True
    gait = client.get(f"/trials/{tid}/gait").json()  # the API and the exports say it too
    assert (gait["voided"], gait["void_reason"]) == (True, "wrong patient walked") and gait["consistency"]["ok"]
    assert client.get(f"/trials/{tid}/steps").json()["voided"] is True
    csv_text = client.get(f"/trials/{tid}/steps", params={"format": "csv"}).text
    assert csv_text.startswith("# VOID - not for clinical use: wrong patient walked\n")
    assert [t["voided"] for t in client.get("/trials", params={"subject_id": "P102"}).json()] == [True]
    other = _trial(server, walk, walk.to_dict(), subject="P107")
    assert client.get(f"/trials/{other}/gait").json()["voided"] is False
    assert not client.get(f"/trials/{other}/steps", params={"format": "csv"}).text.startswith("# VOID")


@pytest.mark.parametrize("n,text", [(1, "1st"), (2, "2nd"), (3, "3rd"), (4, "4th"), (11, "11th"), (12, "12th"),
                                    (13, "13th"), (21, "21st"), (41, "41st"), (43, "43rd"), (51, "51st"),
                                    (61, "61st"), (100, "100th"), (111, "111th")])
def test_percentiles_are_ordinals(n, text):
    assert ordinal(n) == text


def test_under_70_gait_speed_is_a_percentage_of_the_age_sex_mean_and_the_rest_has_no_reference(server, walk):
    _, client, _, _ = server
    tid = _trial(server, walk, walk.to_dict(), subject="P103")
    client.put("/patients/P103", json={"sex": "male", "birth_year": time.gmtime().tm_year - 45})
    js = client.get(f"/trials/{tid}/parameters").json()
    speed = next(p for p in js["parameters"] if p["name"] == "gait_speed_m_s")
    ref = js["gait_speed_reference"]
    assert ref["mean_m_s"] == 1.43 and ref["z"] is None and (ref["age_from"], ref["age_to"]) == (40, 49)
    assert ref["pct_of_mean"] == pytest.approx(100 * speed["mean"] / 1.43, abs=0.1)
    # Bohannon 1997's row for men 40-49 has no checked SD: mean only, no range, no z-score, no finding
    assert speed["normal_range"] is None and speed["z"] is None and speed["norm_source"] is None
    assert js["norm_summary"].startswith("No reference for this patient (the normative table has no normal range "
                                         "for this age and sex)") and not any("Gait speed" in f for f in js["flags"])
    others = [p for p in js["parameters"] if p["name"] not in ("gait_speed_m_s",)]
    assert all(p["normal_range"] is None and p["z"] is None for p in others)
    text = " ".join(_pdf_pages(client, tid))
    assert f"is {ref['pct_of_mean']:.0f} % of the mean comfortable speed of healthy men aged 40-49" in text
    assert "no z-score or normal range is available" in text


def test_a_camera_outage_during_the_trial_is_a_data_problem_so_the_trial_does_not_look_normal(server, walk):
    """The issue's visit: 8 steps computed with "No camera images for 5.1 s" and nothing else said."""
    _, client, _, _ = server
    tid = _trial(server, walk, walk.to_dict(), subject="P104",
                 stored={"data_quality": {"recorded_s": 20.0, "duration_s": 14.9, "nominal_fps": 30.0}})
    js = client.get(f"/trials/{tid}/parameters").json()
    assert js["data_problems"][0].startswith("Data problem, not a clinical finding: no camera images for 5.1 s of "
                                             "the 20.0 s between Start and Stop")
    assert "no camera images for 5.1 s" in " ".join(_pdf_pages(client, tid))
    fine = _trial(server, walk, walk.to_dict(), subject="P105",
                  stored={"data_quality": {"recorded_s": 20.0, "duration_s": 19.0, "nominal_fps": 30.0}})
    assert client.get(f"/trials/{fine}/parameters").json()["data_problems"] == []


def _kinematics_of(walk_report, times, points, names) -> dict:
    """kinematics.json as the worker writes it, from the walker's angles measured on its keypoints."""
    from gaitcap.reconstruction.kinematics.geometric import keypoint_angles
    from gaitcap.reconstruction.kinematics.report import kinematics_report
    from gaitcap.services.kinematics.files import norm_bands

    a, zero = keypoint_angles(points, names), np.zeros(len(times))
    coords = {"pelvis_tilt": zero, "pelvis_list": zero, "pelvis_rotation": zero, "L5_S1_Flex_Ext": zero}
    for model, ours in (("hip_flexion", "hip_flexion"), ("hip_adduction", "hip_adduction"),
                        ("knee_angle", "knee_flexion"), ("ankle_angle", "ankle_dorsiflexion")):
        coords |= {f"{model}_{s[0]}": a[ours][s] for s in ("left", "right")}
    coords |= {f"hip_rotation_{s}": zero for s in "lr"}
    rep = kinematics_report(coords, times, walk_report.steps, norms=norm_bands(), held={"pelvis_tilt": "held"})
    return {"available": True, **rep.to_dict()}


def test_one_trial_with_every_figure_is_two_pages_void_on_both_and_no_heading_left_at_a_page_foot(server):
    """Heel traces, footprints, joint-angle curves and key values, norms, a previous visit: 2 pages."""
    from gaitcap.reconstruction.gait import analyze_gait
    from gaitcap.reconstruction.skeletons import get_skeleton
    from gaitcap.services.processing.report_plot import heel_traces_png
    from gaitcap.simulator.params import WalkParams
    from gaitcap.simulator.path import Room, plan_walk
    from gaitcap.simulator.walker import simulate_body
    from pypdf import PdfReader

    _, client, _, settings = server
    names, times, params = list(get_skeleton("halpe26").joint_names), np.arange(360) / 30.0, WalkParams()
    points = simulate_body(plan_walk(params, 12.0, Room(), seed=0), params, times)
    report = analyze_gait(points, times, names)
    kinematics = _kinematics_of(report, times, points, names)
    for session in ("visit-1", "visit-2"):
        tid = _trial(server, report, report.to_dict(), subject="P106")
        client.post(f"/trials/{tid}/correct", json={"session": session, "reason": "visit label"})
        files = trial_files(settings.data_dir, tid)
        files.stage_file("preliminary", "report_png").write_bytes(heel_traces_png(report, points, times, names))
        files.stage_file("preliminary", "kinematics_json").parent.mkdir(parents=True, exist_ok=True)
        files.stage_file("preliminary", "kinematics_json").write_text(json.dumps(kinematics))
        time.sleep(0.01)
    client.put("/patients/P106", json={"sex": "female", "birth_year": time.gmtime().tm_year - 74})
    client.post(f"/trials/{tid}/mark-void", json={"reason": "shoes left on"})
    pdf = client.get(f"/trials/{tid}/report.pdf").content
    pages = [p.extract_text() for p in PdfReader(io.BytesIO(pdf)).pages]
    assert len(pages) == 2 and len(pdf) < 200 * 1024
    assert all("VOID - not for clinical use: shoes left on" in p for p in pages)
    text = " ".join(" ".join(p.split()) for p in pages)
    for heading in ("Findings to note", "Heel traces and detected steps", "Footprints of the first straight pass",
                    "Joint kinematics", "Key value (degrees)", "Gait Profile Score (Baker 2009)",
                    "Method and software", "Normative reference", "Signature"):
        assert heading in text, heading
    for page in pages:  # the last line before the footer is never a heading
        lines = [ln for ln in page.splitlines() if ln.strip() and not ln.startswith("Trial ")]
        assert lines[-1].strip() not in ("Findings to note", "Method and software", "Normative reference", "Data quality")


def test_the_consistency_block_the_processing_stored_is_the_one_shown(server, walk):
    """The one processing path stores each stage's rules under ``consistency`` (result report, gait.json):
    the page and the report use that block rather than checking again."""
    _, client, _, _ = server
    stored = {"ok": False, "frame_period_s": 1 / 30, "rules_checked": ["stance_support"], "rules_not_checked": {},
              "comparisons": 1, "parameters_in_doubt": ["double_support_pct", "stance_pct"],
              "failures": [{"rule": "stance_support", "parameter": "stance_pct", "side": "left",
                            "message": "stance = single support + double support does not hold (left mean)"}]}
    tid = _trial(server, walk, {**walk.to_dict(), "consistency": stored}, subject="P108")
    for where in (client.get(f"/trials/{tid}/parameters").json(), client.get(f"/trials/{tid}/gait").json()):
        assert where["consistency"] == stored
    js = client.get(f"/trials/{tid}/parameters").json()
    assert js["data_problems"] == ["Data problem, not a clinical finding: stance = single support + double support "
                                   "does not hold (left mean)."]
    assert {p["name"] for p in js["parameters"] if p["in_doubt"]} == {"double_support_pct", "stance_pct"}
