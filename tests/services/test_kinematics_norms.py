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
    (45, 2.0, "adults (patient 45 years)"), (18, 2.0, "adults"), (17, 1.0, "children and adolescents (patient 17"),
    (None, 1.0, "age is not recorded")])
def test_the_band_follows_the_patients_age(age, level, population):
    s = choose_norms(age, children=CHILDREN, adults=ADULTS, adult_source="Adult study", variables=VARS)
    assert s.bands["knee_flexion"].mean[50] == level and population in s.population
    if level == 2.0:  # an adult gets no children's band where the adult data has none
        assert "hip_adduction" not in s.bands and "adult" in s.missing["hip_adduction"] and s.source == "Adult study"
    else:
        assert "hip_adduction" in s.bands and "Schwartz" in s.source and "trunk_flexion" in s.missing
    assert s.to_dict()["bands"]["knee_flexion"]["sd_deg"][0] == 2.0


def test_adults_fall_back_to_the_childrens_band_when_no_adult_file_is_installed():
    s = choose_norms(60, children=CHILDREN, adults={}, adult_source="", variables=VARS)
    assert "children" in s.population and "60 years" in s.population and "hip_adduction" in s.bands
    none = choose_norms(60, children={}, adults={}, adult_source="", variables=VARS)
    assert not none.bands and none.to_dict()["source"] is None and none.missing["knee_flexion"]


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
