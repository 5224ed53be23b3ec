"""Normal-gait bands for the joint angles: chosen by the patient's age (children's data of Schwartz et al.
2008, adults' of the BioCV dataset), read from the installed files, never made up."""

import numpy as np
import pytest
from gaitcap.reconstruction.kinematics.norms import NormBand, bands_from_curves, choose_norms


def _band(name: str, level: float) -> NormBand:
    return NormBand(name, np.full(101, level), np.full(101, 2.0))


CHILDREN = {n: _band(n, 1.0) for n in ("knee_flexion", "hip_adduction")}
ADULTS = {"knee_flexion": _band("knee_flexion", 2.0)}
VARS = ("knee_flexion", "hip_adduction", "trunk_flexion")


@pytest.mark.parametrize(("age", "level", "population"), [
    (45, 2.0, "adults (patient 45 years)"), (18, 2.0, "adults"), (65, 2.0, "adults (patient 65"),
    (17, 1.0, "children and adolescents (patient 17"), (4, 1.0, "children and adolescents (patient 4")])
def test_the_band_follows_the_patients_age(age, level, population):
    s = choose_norms(age, children=CHILDREN, adults=ADULTS, adult_source="Adult study", variables=VARS)
    assert s.bands["knee_flexion"].mean[50] == level and population in s.population
    if level == 2.0:  # an adult gets no children's band where the adult data has none
        assert "hip_adduction" not in s.bands and "adult" in s.missing["hip_adduction"] and s.source == "Adult study"
    else:
        assert "hip_adduction" in s.bands and "Schwartz" in s.source and "trunk_flexion" in s.missing
    assert s.to_dict()["bands"]["knee_flexion"]["sd_deg"][0] == 2.0


@pytest.mark.parametrize(("age", "why"), [
    (None, "the patient's age is not recorded"), (76, "the patient's age (76 years) is outside"),
    (66, "(66 years) is outside")])
def test_a_patient_outside_every_bands_population_gets_no_reference_for_this_patient(age, why):
    """No children's band for an unknown age; a 76-year-old is not compared with the 18-65 adult band."""
    s = choose_norms(age, children=CHILDREN, adults=ADULTS, adult_source="Adult study", variables=VARS)
    d = s.to_dict()
    assert not s.bands and d["bands"] == {} and d["source"] is None and d["population_range"] is None
    assert d["no_reference"].startswith("no reference for this patient: the patient's age")
    assert why in d["no_reference"] and "under 18 years (Schwartz 2008)" in d["no_reference"]
    assert "18-65 years (BioCV 2024)" in d["no_reference"]
    assert all(m == d["no_reference"] for m in d["missing"].values()) and set(d["missing"]) == set(VARS)


def test_the_population_ranges_are_recorded_with_the_bands_provenance():
    adult = choose_norms(30, children=CHILDREN, adults=ADULTS, adult_source="Adult study", variables=VARS).to_dict()
    assert adult["population_range"]["age_min_years"] == 18 and adult["population_range"]["age_max_years"] == 65
    assert "myogait 0.9.2" in adult["population_range"]["provenance"] and adult["no_reference"] is None
    child = choose_norms(9, children=CHILDREN, adults=ADULTS, adult_source="", variables=VARS).to_dict()
    assert child["population_range"]["age_min_years"] is None and child["population_range"]["age_max_years"] == 17


def test_no_band_falls_back_to_another_population_when_a_file_is_not_installed():
    s = choose_norms(60, children=CHILDREN, adults={}, adult_source="", variables=VARS)
    assert not s.bands and "(60 years) is outside" in s.no_reference and "BioCV" not in s.no_reference
    none = choose_norms(60, children={}, adults={}, adult_source="", variables=VARS)
    assert not none.bands and none.to_dict()["source"] is None
    assert none.missing["knee_flexion"] == "no reference for this patient: no normative data is installed"


def test_a_malformed_curve_is_refused_naming_it():
    good = {"percent": list(range(0, 101, 4)), "mean_deg": [0.0] * 26, "sd_deg": [1.0] * 26}
    assert bands_from_curves({"variables": {"knee_flexion": good}})["knee_flexion"].mean.shape == (101,)
    with pytest.raises(ValueError, match="ankle_dorsiflexion"):
        bands_from_curves({"variables": {"ankle_dorsiflexion": {**good, "sd_deg": [1.0] * 5}}})
    with pytest.raises(ValueError, match="hip_flexion"):
        bands_from_curves({"variables": {"hip_flexion": {"percent": good["percent"]}}})


def test_installed_adult_band_is_a_healthy_adults_gait():
    from gaitcap.services.kinematics.files import adult_norms_file, norms_for_age

    if not adult_norms_file().is_file():
        pytest.skip(f"adult normal-gait data not installed ({adult_norms_file()}; deploy/bootstrap.sh)")
    s = norms_for_age(40)
    assert "BioCV" in s.source and "Evans" in s.source and s.population.startswith("adults")
    knee, ankle, hip = (s.bands[n].mean for n in ("knee_flexion", "ankle_dorsiflexion", "hip_flexion"))
    assert 55.0 <= knee[60:].max() <= 70.0 and knee[:10].max() < 25.0  # peak swing flexion; loading response
    assert ankle[50:70].min() < -10.0 and hip[40:60].min() < -10.0  # push-off plantarflexion, hip extension
    assert set(s.missing) >= {"hip_adduction", "pelvis_obliquity"}  # no adult frontal-plane source installed


def test_the_standalone_figure_says_no_reference_for_this_patient_and_draws_only_the_compared_bands():
    from gaitcap.reconstruction.kinematics.key_norms import drawn_bands, undrawn
    from gaitcap.services.kinematics.plot import figure_title

    none = choose_norms(None, children=CHILDREN, adults=ADULTS, adult_source="Adult study", variables=VARS)
    assert figure_title({"norms": none.to_dict()}).startswith(
        "Joint kinematics (no reference for this patient: the patient's age is not recorded")
    bands = {v: _band(v, 1.0) for v in ("knee_flexion", "hip_flexion", "ankle_dorsiflexion")}
    adult = choose_norms(40, children={}, adults=bands, adult_source="Adult study", variables=VARS).to_dict()
    k = {"norms": adult}
    assert adult["not_drawn"] == undrawn(adult["bands"]) and set(adult["not_drawn"]) == {"hip_flexion", "ankle_dorsiflexion"}
    assert set(drawn_bands(k)) == {"knee_flexion"} and "grey: normal mean +- 1 SD, adults" in figure_title(k)
