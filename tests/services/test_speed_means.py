"""Adult gait speed by decade and sex (Bohannon & Andrews 2011 stratum means, no SD): the patient's speed as
a percentage of the age-sex mean, never a z-score; bad rows named by line and column."""

import pytest
from gaitcap.services.reports.speed_means import compare_speed, parse_speed_means, speed_means

HEAD = "# comment\nage_from,age_to,sex,parameter,unit,mean\n"


def test_the_shipped_table_holds_both_sexes_by_decade_with_the_abstracts_extremes():
    rows = speed_means()
    assert len(rows) == 14 and {r.sex for r in rows} == {"female", "male"}
    by = {(r.sex, r.age_from): r.mean_m_s for r in rows}
    # the abstract: highest stratum men 40-49 143.4 cm/s, lowest women 80-99 94.3 cm/s (rounded in the table)
    assert by[("male", 40)] == pytest.approx(1.434, abs=0.005) and by[("female", 80)] == pytest.approx(0.943, abs=0.005)
    assert max(by.values()) == by[("male", 40)] and min(by.values()) == by[("female", 80)]


def test_speed_as_a_percentage_of_the_age_sex_mean_without_a_z_score():
    found = compare_speed(1.05, sex="female", age=64)
    assert found.reference.age_from == 60 and found.pct_of_mean == pytest.approx(100 * 1.05 / 1.24)
    d = found.to_dict()
    assert d["z"] is None and d["pct_of_mean"] == pytest.approx(84.7) and "no z-score" in d["text"]
    assert "women aged 60-69" in d["text"] and "Bohannon" in d["text"]
    for sex, age in (("", 64), ("female", None), ("male", 19)):
        assert compare_speed(1.05, sex=sex, age=age) is None
    assert compare_speed(float("nan"), sex="male", age=50) is None


@pytest.mark.parametrize("row,where", [("20,29,male,cadence,steps/min,110", "column parameter"),
                                       ("20,29,other,gait_speed,m/s,1.3", "column sex"),
                                       ("20,29,male,gait_speed,m/s,13", "column mean"),
                                       ("twenty,29,male,gait_speed,m/s,1.3", "whole years")])
def test_a_bad_row_is_refused_naming_line_and_column(row, where):
    with pytest.raises(ValueError, match=f"speeds.csv line 3.*{where}"):
        parse_speed_means(HEAD + row + "\n", "speeds.csv")
