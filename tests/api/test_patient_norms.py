"""Norms that match the patient, over REST and in the PDF: a band is used only for a patient inside its
population. A patient without age or sex gets "no reference for this patient" everywhere; a 76-year-old
gets the older adults' spatiotemporal ranges (clipped at 0: no negative width) but no joint-angle band
(the adult band's 15 adults are 18-65); a man of 30 gets his decade-and-sex row and the adult band; the
charts' bands are exactly those the table compares with."""

import io
import time

import pytest
from gaitcap.reconstruction.kinematics.clinical import KEY_VALUES

from .test_kinematics_page import _trial, walk  # noqa: F401  (walk: the module's fixture)

NO_REF = "no reference for this patient"


def _pdf_text(client, tid) -> str:
    from pypdf import PdfReader

    pdf = client.get(f"/trials/{tid}/report.pdf")
    assert pdf.status_code == 200
    return " ".join(" ".join(p.extract_text().split()) for p in PdfReader(io.BytesIO(pdf.content)).pages)


def _patient(client, subject: str, *, sex: str, age: int) -> None:
    assert client.put(f"/patients/{subject}", json={"sex": sex, "birth_year": time.gmtime().tm_year - age}).status_code == 200


def test_a_patient_without_age_or_sex_has_no_reference_for_this_patient_everywhere(server, walk):  # noqa: F811
    _, client, _, _ = server
    _, kin = walk
    tid = _trial(server, walk, subject="N1", kinematics=kin)
    js = client.get(f"/trials/{tid}/parameters").json()
    assert js["age"] is None and not js["sex"]
    assert js["norm_summary"].startswith("No reference for this patient (sex and birth year not recorded)")
    assert all(p["normal_range"] is None and p["z"] is None for p in js["parameters"]) and not js["flags"]
    said = client.get(f"/trials/{tid}/gait").json()["findings"]  # the stage's findings as GET /gait gives them
    assert js["norm_summary"].startswith(said["norm_summary"]) and said["with_reference"] == 0 and not said["findings"]
    assert said["norm_summary"].startswith("No reference for this patient (sex and birth year not recorded)")
    k = client.get(f"/trials/{tid}/kinematics").json()
    assert k["norms"]["bands"] == {} and k["norms"]["population_range"] is None  # no children's band either
    assert k["norms"]["no_reference"].startswith(f"{NO_REF}: the patient's age is not recorded")
    assert {n["no_reference"] for n in k["key_value_norms"].values()} == {NO_REF}
    assert all(n["normal_deg"] is None for n in k["key_value_norms"].values()) and k["gait_profile"] is None
    text = _pdf_text(client, tid)
    assert "No reference for this patient (sex and birth year not recorded)" in text
    assert "No normal band: No reference for this patient: the patient's age is not recorded" in text
    assert "Normal: no reference for this patient" in text and "no key value is called normal or abnormal" in text
    assert "Grey band: normal mean" not in text and "normal range for age and sex;" not in text


def test_a_76_year_old_gets_older_adults_ranges_clipped_at_zero_and_no_joint_angle_band(server, walk):  # noqa: F811
    _, client, _, _ = server
    _, kin = walk
    tid = _trial(server, walk, subject="N2", kinematics=kin)
    _patient(client, "N2", sex="female", age=76)
    js = client.get(f"/trials/{tid}/parameters").json()
    ranges = {p["name"]: p["normal_range"] for p in js["parameters"] if p["normal_range"] is not None}
    assert len(ranges) >= 10 and all(0.0 <= lo < hi for lo, hi in ranges.values())  # never a negative width
    assert ranges["step_width_mm"] == pytest.approx([0.0, 155.4])  # 77 +- 1.96 x 40 mm, clipped at 0
    assert js["norm_summary"].startswith(f"{len(ranges)} of ")
    k = client.get(f"/trials/{tid}/kinematics").json()
    assert k["norms"]["bands"] == {} and "the patient's age (76 years) is outside" in k["norms"]["no_reference"]
    assert "healthy adults, 18-65 years (BioCV 2024)" in k["norms"]["no_reference"]
    text = _pdf_text(client, tid)
    assert "0-155" in text and "-1-155" not in text
    assert "Joint angles: No reference for this patient: the patient's age (76 years) is outside" in text


def test_a_man_of_30_gets_his_decade_row_and_the_adult_band_drawn_where_the_table_compares(server, walk):  # noqa: F811
    _, client, _, _ = server
    _, kin = walk
    tid = _trial(server, walk, subject="N3", kinematics=kin)
    _patient(client, "N3", sex="male", age=30)
    js = client.get(f"/trials/{tid}/parameters").json()
    ref = js["gait_speed_reference"]  # the decade-and-sex mean (no SD: no range, no z-score)
    assert (ref["sex"], ref["age_from"], ref["age_to"]) == ("male", 30, 39) and ref["z"] is None
    k = client.get(f"/trials/{tid}/kinematics").json()
    norms, kv = k["norms"], k["key_value_norms"]
    assert norms["population"] == "adults (patient 30 years)" and norms["no_reference"] is None
    assert (norms["population_range"]["age_min_years"], norms["population_range"]["age_max_years"]) == (18, 65)
    assert set(norms["not_drawn"]) == {"hip_flexion", "ankle_dorsiflexion"}
    for var in k["curves"]:  # the chart draws a band exactly where the table compares a point value with it
        drawn = var in norms["bands"] and var not in norms["not_drawn"]
        points = [n for n, (v, _) in KEY_VALUES.items() if v == var and not n.endswith("_rom_deg")]
        assert all((kv[n]["normal_range_deg"] is not None) == drawn for n in points), var
    for name in ("ankle_rom_deg", "hip_flexion_rom_deg", "knee_flexion_rom_deg"):  # ranges: whatever the zero
        assert kv[name]["no_reference"] is None and 0 < kv[name]["lower_limit_deg"] < kv[name]["normal_deg"]
    assert kv["ankle_minimum_deg"]["label"] == "Ankle peak plantarflexion (dorsiflexion +)"
    left = kin["key_values"]["left"]["ankle_minimum_deg"]["mean"]
    curve = [v for v in k["curves"]["ankle_dorsiflexion"]["left"]["mean_deg"] if v is not None]
    assert left < 0 and left <= min(curve) + 1e-9  # signed as the curve: the mean of the cycles' minima
