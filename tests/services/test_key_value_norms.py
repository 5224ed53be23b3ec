"""Joint-angle key values against the installed normal bands, like the spatiotemporal parameters: the norm
source's own mean curve, fed through the key values and the report's findings, is normal with z = 0 for
every key value (same sign and zero), and a curve moved by more than the band is flagged."""

import copy
import math

import numpy as np
import pytest
from gaitcap.reconstruction.gait.stability import MIN_CYCLES_PER_SIDE, loo_mean_range
from gaitcap.reconstruction.kinematics.clinical import DEFAULT_TOE_OFF_PCT, KEY_VALUES, key_values
from gaitcap.reconstruction.kinematics.cycles import CycleCurves
from gaitcap.reconstruction.kinematics.key_norms import (
    NO_REFERENCE,
    UNVALIDATED_ZERO,
    key_norm,
    key_norms,
    no_reference,
)
from gaitcap.services.kinematics.files import norms_for_age
from gaitcap.services.reports.findings import key_value_findings

AGES = {"children": 9, "adults": 40}


def _norm_set(who: str) -> dict:
    bands = norms_for_age(AGES[who]).to_dict()
    if not bands["bands"]:
        pytest.skip("normal bands not installed (deploy/bootstrap.sh)")
    return bands


def _kinematics_of(curves_by_variable: dict, norms: dict) -> dict:
    """kinematics.json as the report reads it: both sides' key values of MIN_CYCLES_PER_SIDE identical
    cycles each (the fewest a finding may rest on)."""
    n = MIN_CYCLES_PER_SIDE
    per_side = {var: CycleCurves(np.stack([c] * n), np.full(n, DEFAULT_TOE_OFF_PCT)) for var, c in curves_by_variable.items()}
    values = key_values(per_side)
    return {"key_values": {"left": values, "right": values}, "norms": norms}


@pytest.mark.parametrize("who", ["children", "adults"])
def test_the_sources_own_mean_curve_is_normal_with_z_zero_for_every_key_value(who):
    norms = _norm_set(who)
    bands = norms["bands"]
    k = _kinematics_of({var: np.asarray(b["mean_deg"]) for var, b in bands.items()}, norms)
    by_name = key_norms(bands)
    assert set(by_name) == {n for n, (var, _) in KEY_VALUES.items()
                            if var in bands and (var not in UNVALIDATED_ZERO or n.endswith("_rom_deg"))}
    shown = [n for n, (var, _) in KEY_VALUES.items() if var in bands and k["key_values"]["left"][n]["n"]]
    for name, norm in by_name.items():
        value = k["key_values"]["left"][name]["mean"]
        assert value == pytest.approx(norm.normal_deg, abs=1e-9), name
        if name.endswith("_rom_deg"):
            assert math.isnan(norm.z(value)) and norm.band() is None and 0 <= norm.lower_deg < value, name
        else:
            assert norm.z(value) == pytest.approx(0.0, abs=1e-9) and norm.sd_deg > 0, name
    said = key_value_findings(k)
    point_values = [n for n in by_name if not n.endswith("_rom_deg")]
    assert said.findings == () and said.outside == 0
    assert point_values and said.with_reference == 2 * len(by_name) and said.total == 2 * len(shown)
    assert "none outside it." in said.summary and said.summary.endswith("no reference: the zero of this angle is not validated.")
    # signed like the curve: the ankle's minimum (peak plantarflexion) is the band's negative minimum
    ankle = bands["ankle_dorsiflexion"]
    minimum = key_norm("ankle_minimum_deg", ankle["mean_deg"], ankle["sd_deg"])
    assert minimum.normal_deg == pytest.approx(np.min(ankle["mean_deg"])) and minimum.normal_deg < -5.0


def test_a_knee_bent_beyond_the_band_at_initial_contact_is_flagged_on_the_side_it_is():
    """The issue's knee: 23.6 / 21.8 deg at initial contact against a normal of about 5 deg."""
    norms = _norm_set("adults")
    bands = norms["bands"]
    knee = np.asarray(bands["knee_flexion"]["mean_deg"])
    norm = key_norm("knee_flexion_initial_contact_deg", knee, bands["knee_flexion"]["sd_deg"])
    assert norm.at_pct == 0
    k = _kinematics_of({"knee_flexion": knee}, norms)
    k["key_values"]["left"] = {**k["key_values"]["left"],
                               "knee_flexion_initial_contact_deg": _stats([norm.normal_deg + 5 * norm.sd_deg] * 4)}
    said = key_value_findings(k)
    assert said.outside == 1 and len(said.findings) == 1
    finding = said.findings[0]
    assert finding.startswith("Knee flexion at initial contact (flexion +): left") and "above, z +5.0" in finding
    assert "right" not in finding and "at 0 % of the cycle" in finding


@pytest.mark.parametrize("who", ["children", "adults"])
def test_hip_flexion_far_outside_the_band_raises_no_finding_its_zero_is_not_validated(who):
    """The pelvis's tilt is not measured, and the sources' hip flexion differs by about their pelvic tilt:
    hip flexion's key values are shown with "no reference", never judged; the knee still is."""
    norms = _norm_set(who)
    bands = norms["bands"]
    hip = np.asarray(bands["hip_flexion"]["mean_deg"]) + 40.0
    knee = np.asarray(bands["knee_flexion"]["mean_deg"]) + 40.0
    said = key_value_findings(_kinematics_of({"hip_flexion": hip, "knee_flexion": knee}, norms))
    assert said.findings and all(f.startswith("Knee") for f in said.findings)
    assert said.no_reference == ("hip_flexion",)
    assert said.summary.endswith("Hip flexion: no reference: the zero of this angle is not validated.")
    hip_points = [n for n, (var, _) in KEY_VALUES.items() if var == "hip_flexion" and not n.endswith("_rom_deg")]
    assert not set(hip_points) & set(said.norms) and "hip_flexion_rom_deg" in said.norms  # a range: judged
    assert all(no_reference(n) == NO_REFERENCE == "no reference: the zero of this angle is not validated"
               for n in hip_points)
    assert no_reference("knee_flexion_initial_contact_deg") is None and no_reference("hip_flexion_rom_deg") is None
    assert no_reference("ankle_minimum_deg") == NO_REFERENCE  # the foot's zero neither


def _stats(cycles: list[float]) -> dict:
    """A side's key value as kinematics.json stores it: mean, SD, n and each cycle's value (degrees)."""
    x = np.asarray(cycles, dtype=float)
    return {"mean": float(x.mean()), "sd": float(x.std(ddof=1)) if x.size > 1 else None, "n": int(x.size),
            "values": [float(v) for v in x]}


def test_a_key_value_finding_needs_enough_cycles_and_survives_leaving_out_any_one():
    """The spatiotemporal findings' rule for joint angles: a knee outside the band at initial contact is a
    finding only with at least MIN_CYCLES_PER_SIDE cycles on its side and outside whichever single cycle is
    left out; one bent cycle among normal ones, or too few cycles, is stated as numbers ("Not a finding"),
    never as a finding, and is not counted outside the range."""
    norms = _norm_set("adults")
    bands = norms["bands"]
    knee = np.asarray(bands["knee_flexion"]["mean_deg"])
    norm = key_norm("knee_flexion_initial_contact_deg", knee, bands["knee_flexion"]["sd_deg"])
    base = _kinematics_of({"knee_flexion": knee}, norms)
    far, normal = norm.normal_deg + 4 * norm.sd_deg, norm.normal_deg

    def judged(cycles: list[float]):
        k = copy.deepcopy(base)
        k["key_values"]["left"] = {**k["key_values"]["left"], "knee_flexion_initial_contact_deg": _stats(cycles)}
        return key_value_findings(k)

    held = judged([far] * MIN_CYCLES_PER_SIDE)
    assert held.outside == 1 and held.withheld == () and "left" in held.findings[0]
    few = judged([far] * (MIN_CYCLES_PER_SIDE - 1))
    assert few.findings == () and few.outside == 0
    assert few.withheld == (f"Not a finding: Knee flexion at initial contact (flexion +): left {far:.1f} (above, "
                            f"z +4.0) deg, outside the normal range {norm.band()[0]:.1f} to {norm.band()[1]:.1f} deg of "
                            f"the band at 0 % of the cycle, but too few gait cycles to say it "
                            f"({MIN_CYCLES_PER_SIDE - 1} on this side; at least {MIN_CYCLES_PER_SIDE} a side).",)
    # one impossible cycle: the mean is outside, leaving that cycle out brings it back inside
    one = [normal] * (MIN_CYCLES_PER_SIDE - 1) + [normal + 12 * MIN_CYCLES_PER_SIDE * norm.sd_deg]
    assert norm.verdict(float(np.mean(one))) == 1
    lo, hi = loo_mean_range(one)
    assert norm.verdict(lo) == 0 and lo == pytest.approx(normal)
    single = judged(one)
    assert single.findings == () and single.outside == 0 and len(single.withheld) == 1
    assert single.withheld[0].endswith(f"but it rests on single cycles ({lo:.1f} to {hi:.1f} deg leaving out one "
                                       "cycle at a time).")
    # a mean that is not that of its cycles is no finding either
    k = copy.deepcopy(base)
    k["key_values"]["left"] = {**k["key_values"]["left"],
                               "knee_flexion_initial_contact_deg": {**_stats([normal] * 4), "mean": far}}
    assert key_value_findings(k).withheld[0].endswith("these numbers are not those of the gait cycles.")
    # stored kinematics.json of an earlier version has no per-cycle values: never a finding
    k["key_values"]["left"]["knee_flexion_initial_contact_deg"] = {"mean": far, "sd": 1.0, "n": 4}
    assert key_value_findings(k).findings == ()
    assert all(math.isnan(v) for v in loo_mean_range([1.0]) + loo_mean_range([1.0, math.nan]))


def test_a_key_value_without_a_rule_or_with_a_short_band_is_refused():
    with pytest.raises(ValueError, match="unknown key value"):
        key_norm("knee_twist_deg", np.zeros(101), np.ones(101))
    with pytest.raises(ValueError, match="101 points"):
        key_norm("hip_peak_flexion_deg", np.zeros(51), np.ones(51))


def test_gait_profile_score_is_zero_on_the_band_and_names_what_it_leaves_out():
    """Baker 2009: GVS = RMS over the cycle (every 2 %) of curve minus band mean; GPS = RMS of the GVS."""
    from gaitcap.reconstruction.kinematics.gait_profile import gait_profile

    norms = _norm_set("adults")
    bands = norms["bands"]
    curves = {var: {side: {"mean_deg": list(b["mean_deg"])} for side in ("left", "right")} for var, b in bands.items()}
    k = {"curves": curves, "norms": norms, "not_measured": {"pelvis_tilt": "held near 0 by the fit"}}
    profile = gait_profile(k)
    assert profile.overall_gps_deg == pytest.approx(0.0, abs=1e-9)
    assert profile.not_included["pelvis_tilt"].startswith("not measured")
    assert profile.not_included["hip_flexion"].startswith("zero not validated")
    assert "foot_progression" in profile.not_included and set(profile.gvs_deg["left"]) <= set(bands)
    shifted = {**curves, "knee_flexion": {"left": {"mean_deg": [v + 6.0 for v in bands["knee_flexion"]["mean_deg"]]},
                                          "right": curves["knee_flexion"]["right"]}}
    moved = gait_profile({**k, "curves": shifted})
    n_left = len(moved.gvs_deg["left"])
    assert moved.gvs_deg["left"]["knee_flexion"] == pytest.approx(6.0) and moved.gvs_deg["right"]["knee_flexion"] == 0.0
    assert moved.gps_deg["left"] == pytest.approx(6.0 / math.sqrt(n_left))
    assert moved.to_dict()["source"].startswith("Baker")


def test_hip_rotation_is_never_judged_against_the_band_not_drawn_nor_in_the_profile_score():
    """Against Plug-in-Gait on the real walks our hip rotation does not follow (key_norms.UNVALIDATED_COURSE):
    the children's band has it, the chart leaves it out saying why, and the Gait Profile Score names it left
    out; a far-off hip rotation moves no score."""
    from gaitcap.reconstruction.kinematics.gait_profile import gait_profile

    norms = _norm_set("children")
    bands = norms["bands"]
    assert "hip_rotation" in bands and norms["not_drawn"]["hip_rotation"].startswith("band not drawn: this angle is "
                                                                                    "not validated (against Plug-in-Gait")
    curves = {var: {side: {"mean_deg": list(b["mean_deg"])} for side in ("left", "right")} for var, b in bands.items()}
    curves["hip_rotation"] = {side: {"mean_deg": [v + 20.0 for v in bands["hip_rotation"]["mean_deg"]]}
                              for side in ("left", "right")}
    profile = gait_profile({"curves": curves, "norms": norms, "not_measured": {}})
    assert profile.not_included["hip_rotation"].startswith("not validated (against Plug-in-Gait")
    assert "hip_rotation" not in profile.gvs_deg["left"] and profile.overall_gps_deg == pytest.approx(0.0, abs=1e-9)
    assert {"knee_flexion", "hip_adduction", "pelvis_obliquity"} <= set(profile.gvs_deg["left"])


@pytest.mark.parametrize("who", ["children", "adults"])
def test_every_angle_with_a_band_hip_and_ankle_included_reads_its_sources_mean_curve_as_z_zero(who):
    """The sign and zero convention holds for every angle that has a band, also those shown as "no
    reference" (hip, ankle: their zero is not validated for our model, not the machinery's): the source's
    own mean curve through the key values gives each key value the band's normal value, z = 0, normal."""
    norms = _norm_set(who)
    bands = norms["bands"]
    k = _kinematics_of({var: np.asarray(b["mean_deg"]) for var, b in bands.items()}, norms)
    names = [n for n, (var, _) in KEY_VALUES.items() if var in bands]
    assert {KEY_VALUES[n][0] for n in names} >= set(UNVALIDATED_ZERO) | {"knee_flexion"}, sorted(bands)
    for name in names:
        band = bands[KEY_VALUES[name][0]]
        norm = key_norm(name, band["mean_deg"], band["sd_deg"])
        for side in ("left", "right"):
            value = k["key_values"][side][name]["mean"]
            assert value == pytest.approx(norm.normal_deg, abs=1e-9), (name, side)
            if name.endswith("_rom_deg"):
                assert math.isnan(norm.z(value)), name  # a range has no SD: no z-score, no band
                continue
            assert norm.z(value) == pytest.approx(0.0, abs=1e-9) and norm.sd_deg > 0, name
            lo, hi = norm.band()
            assert lo < value < hi, name  # normal


@pytest.mark.parametrize("who", ["children", "adults"])
def test_a_range_of_motion_is_judged_against_the_bands_range_even_where_the_zero_is_not_validated(who):
    """Ankle and hip: their zero is not validated, their ranges of motion are (max - min does not depend on
    it). A curve moved 40 deg keeps its range (no finding); an almost fixed ankle (an eighth of the band's
    swing) has a range below the band's one-sided lower limit: a finding on that side, "below", never
    "above". The limit is conservative (about a quarter of the band's range for the adults' ankle): only
    a gross loss of motion is called."""
    norms = _norm_set(who)
    bands = norms["bands"]
    ankle, hip = (np.asarray(bands[v]["mean_deg"]) for v in ("ankle_dorsiflexion", "hip_flexion"))
    stiff = ankle.mean() + (ankle - ankle.mean()) / 8.0
    k = _kinematics_of({"ankle_dorsiflexion": ankle + 40.0, "hip_flexion": hip + 40.0}, norms)
    n = MIN_CYCLES_PER_SIDE
    k["key_values"]["right"] = key_values({"ankle_dorsiflexion": CycleCurves(np.stack([stiff] * n), np.full(n, 60.0)),
                                           "hip_flexion": CycleCurves(np.stack([hip] * n), np.full(n, 60.0))})
    said = key_value_findings(k)
    rom = said.norms["ankle_rom_deg"]
    assert rom.at_pct is None and math.isnan(rom.sd_deg) and 0 < rom.lower_deg < rom.normal_deg
    assert rom.verdict(np.ptp(stiff)) == -1 and rom.verdict(np.ptp(ankle) / 3) == 0 and rom.verdict(1000.0) == 0
    assert said.findings == (f"Ankle range of motion: right {np.ptp(stiff):.1f} (below) deg, below the normal range "
                             f"(at least {rom.lower_deg:.1f} deg; the band's range of motion is {rom.normal_deg:.1f} deg).",)
    assert "hip_flexion_rom_deg" in said.norms and "hip_peak_flexion_deg" not in said.norms
    assert "ankle_minimum_deg" not in said.norms  # a point value of the ankle: its zero is not validated
