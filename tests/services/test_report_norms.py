"""Normative tables: the shipped one (cited, by decade and sex), a clinic's replacement, bad rows named."""

import math

import pytest
from gaitcap.services.reports.content import PARAMETERS, flags_of, rows_of
from gaitcap.services.reports.norms import load_norms, parse_norms, percentile

CLINIC = """# Source: our lab, 2025
parameter,sex,age_min,age_max,mean,sd,unit,source
cadence_steps_min,female,60,69,110,8,steps/min,lab
step_length_mm,female,60,69,600,50,mm,lab
"""


def test_shipped_table_covers_adults_by_decade_and_sex_with_its_source():
    norms = load_norms()
    for sex in ("female", "male"):
        for age in (20, 35, 47, 52, 68, 79):
            row = norms.find("gait_speed_m_s", sex=sex, age=age)
            assert row is not None and 1.0 < row.mean < 1.6 and 0.05 < row.sd < 0.3, (sex, age)
    assert norms.find("gait_speed_m_s", sex="female", age=85) is None  # outside the published ages
    assert norms.find("gait_speed_m_s", sex="", age=50) is None  # sex not recorded: no comparison
    assert "Bohannon RW" in " ".join(norms.citations) and "Age and Ageing 1997" in " ".join(norms.citations)
    assert {r.parameter for r in norms.rows} <= set(PARAMETERS)


def test_a_clinic_table_gives_z_scores_bands_and_flags(tmp_path):
    path = tmp_path / "norms.csv"
    path.write_text(CLINIC)
    norms = load_norms(path)
    summary = {"num_steps": 20, "cadence_steps_min": 90.0,
               "parameters": {"step_length_mm": {"all": {"n": 20, "mean": 560.0, "sd": 10.0, "cv_pct": 1.8},
                                                 "left": {"mean": 500.0}, "right": {"mean": 620.0}},
                              "step_time_s": {"left": {"mean": 0.64}, "right": {"mean": 0.42}}},
               "asymmetry_pct": {"step_length_mm": 21.4}}
    rows = {r.name: r for r in rows_of(summary, norms, sex="female", age=64)}
    assert rows["step_length_mm"].z == pytest.approx(-0.8)
    assert rows["step_length_mm"].percentile == pytest.approx(percentile(-0.8)) and 21 < percentile(-0.8) < 22
    assert rows["cadence_steps_min"].z == pytest.approx(-2.5)
    assert rows["cadence_steps_min"].left == pytest.approx(60 / 0.64) and rows["cadence_steps_min"].si_pct > 40
    assert math.isnan(rows["gait_speed_m_s"].z)  # no row in the clinic's table
    flags = " ".join(flags_of(tuple(rows.values())))
    assert "Cadence 90.0 steps/min is below the normal range" in flags
    assert "Step length differs between sides: left 500, right 620 mm" in flags


@pytest.mark.parametrize(("text", "words"), [
    ("parameter,sex,age_min,mean,sd,unit,source\n", "missing column(s) age_max"),
    ("parameter,sex,age_min,age_max,mean,sd,unit,source\ncadence_steps_min,female,60,69,110,0,steps/min,x\n",
     "line 2: cadence_steps_min needs sd > 0"),
    ("parameter,sex,age_min,age_max,mean,sd,unit,source\ncadence_steps_min,female,sixty,69,110,8,steps/min,x\n",
     "line 2:"),
])
def test_bad_tables_are_refused_naming_the_line(text, words):
    with pytest.raises(ValueError, match="clinic.csv") as err:
        parse_norms(text, "clinic.csv")
    assert words in str(err.value)
