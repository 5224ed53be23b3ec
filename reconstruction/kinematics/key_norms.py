"""Key joint-angle values against a normal band: the value read off the band's mean curve, the band's SD
where that value is read, and the patient's z-score, exactly like a spatiotemporal parameter's.

A key value read at one point of the cycle (the knee at initial contact, a peak) is compared with the band
at that point: normal value = the key value of the band's mean curve (through the same function as the
patient's, :data:`gaitcap.reconstruction.kinematics.clinical.KEY_VALUES`, so sign and zero are the same),
SD = the band's SD at the percent of the cycle where the mean curve takes it. Outside the normal range:
|z| > 1.96. Pure computation, degrees.

A range of motion (max - min) does not depend on the angle's zero: it is judged against the band's range
of motion also for an angle whose zero is not validated (hip, ankle). A band of means and SDs per point
gives it no SD (the spreads at the two points are not independent), but a one-sided limit holds: each
person's range is at least the difference D of their angle at the two points where the band's mean curve
peaks (a, its maximum) and dips (b, its minimum); D has mean = the band's range and SD <= SD(a) + SD(b)
whatever the correlation. A range below ``range - 1.96 (SD(a) + SD(b))`` is therefore below the 97.5 % of
normal walkers' ranges (normal D): "below the normal range". No upper limit follows (a person's range can
exceed D by any amount), so a range is never called above it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from gaitcap.reconstruction.kinematics.clinical import DEFAULT_TOE_OFF_PCT, KEY_VALUES

Z_OUTSIDE = 1.96
NO_REFERENCE = "no reference: the zero of this angle is not validated"

# variable -> why its zero is not the band's: its key values are shown, never compared with the band.
# Hip flexion is the thigh against the pelvis, and the fit does not measure the pelvis's tilt (it is held
# near 0, docs/kinematics.md): our hip flexion is the thigh against a pelvis assumed level. The sources
# differ by just that: Schwartz 2008 (conventional gait model, pelvis tilted 11.6 deg forward on average)
# reads 18.6 deg of mean hip flexion over the cycle, BioCV 4.8 deg (its knee and ankle agree with
# Schwartz's within 1.1 deg); neither source's hip zero is known to be ours. Ankle dorsiflexion: the
# model's foot, fitted to the heel, toe and ankle keypoints, reads the synthetic walker standing upright
# (truth -0.8 deg both sides) at 4.3 and -0.5 deg (left, right) on the default fit of a 12 s trial, -5.5 on
# average over 30 s: the zero is off by up to 5 deg, about one SD of the band, and differs between sides.
UNVALIDATED_ZERO = {
    "hip_flexion": "pelvic tilt not measured",
    "ankle_dorsiflexion": "foot fit off by up to 5 deg",
}

# variable -> why its curve is never judged against a band (neither drawn over one nor in the Gait Profile
# Score): against a laboratory's reference its course does not follow. Hip rotation (the thigh's turn about
# its own axis) is seen only through the knee's bend and the foot, and a nearly straight knee leaves it
# loose: against Plug-in-Gait on the three real walks (`python bench/validation.py --refine`,
# docs/validation.md) r 0.03-0.75
# and offsets of 5-19 deg (RMSE after them 4-7 deg), where hip flexion and the knee follow at r 0.98-0.999 and
# hip adduction within 2.5 deg after offsets of at most 1.8 deg (r 0.68-0.95).
UNVALIDATED_COURSE = {
    "hip_rotation": "against Plug-in-Gait on three real walks r 0.03-0.75, offsets 5-19 deg",
}


def undrawn(variables) -> dict[str, str]:
    """Variable -> why its band is not drawn under its curve: the chart shows a band only where the table
    compares the angle's values with it at a point, i.e. not for an angle whose zero is not validated (its
    range of motion is still compared, in the table) nor for one whose course is not (never compared)."""
    out = {v: (f"band not drawn: the zero of this angle is not validated ({UNVALIDATED_ZERO[v]}); its range "
               "of motion is compared with the band's in the table") for v in variables if v in UNVALIDATED_ZERO}
    return out | {v: (f"band not drawn: this angle is not validated ({UNVALIDATED_COURSE[v]}); it is not "
                      "compared with the band") for v in variables if v in UNVALIDATED_COURSE}


def drawn_bands(k: Mapping[str, Any]) -> dict:
    """The bands a chart of ``k`` (``kinematics.json`` with its norms) draws: those the table compares
    point values with (``norms.bands`` less ``norms.not_drawn``)."""
    norms = k.get("norms") or {}
    return {v: b for v, b in (norms.get("bands") or {}).items() if v not in (norms.get("not_drawn") or {})}


def is_range(name: str) -> bool:
    """Whether key value ``name`` is a range of motion (max - min: independent of the angle's zero)."""
    return name.endswith("_rom_deg")


def no_reference(name: str) -> str | None:
    """:data:`NO_REFERENCE` for a key value read at a point of a variable in :data:`UNVALIDATED_ZERO`,
    else None (a range of motion does not depend on the zero)."""
    var = KEY_VALUES.get(name, (None,))[0]
    return NO_REFERENCE if var in UNVALIDATED_ZERO and not is_range(name) else None


def _point_of(name: str, mean: np.ndarray, toe: int) -> int | None:
    """The percent of the cycle at which key value ``name`` is read on ``mean``; None for a range."""
    if is_range(name):
        return None
    if name == "knee_flexion_initial_contact_deg":
        return 0
    if name == "knee_peak_flexion_swing_deg":
        return toe + int(np.argmax(mean[toe:]))
    if name == "ankle_peak_dorsiflexion_stance_deg":
        return int(np.argmax(mean[: toe + 1]))
    if name == "ankle_minimum_deg":
        return int(np.argmin(mean))
    if name == "hip_minimum_terminal_stance_deg":
        start = 30
        return start + int(np.argmin(mean[start: max(toe, 31) + 1]))
    if name == "hip_peak_flexion_deg":
        return int(np.argmax(mean))
    raise ValueError(f"key value {name!r}: no rule for where it is read")


@dataclass(frozen=True)
class KeyNorm:
    """The normal value (degrees) of one key value, its SD (NaN for a range of motion) and the percent of
    the cycle where it is read (None for a range); for a range, ``lower_deg``: the one-sided lower limit
    (see the module), NaN otherwise."""

    name: str
    normal_deg: float
    sd_deg: float
    at_pct: int | None
    lower_deg: float = math.nan

    def z(self, value_deg: float) -> float:
        if not (math.isfinite(value_deg) and math.isfinite(self.sd_deg) and self.sd_deg > 0):
            return math.nan
        return (value_deg - self.normal_deg) / self.sd_deg

    def verdict(self, value_deg: float) -> int:
        """-1 below the normal range, +1 above it, 0 inside or not judged (no value; a range above its
        lower limit)."""
        if not math.isfinite(value_deg):
            return 0
        if math.isfinite(self.lower_deg):
            return -1 if value_deg < self.lower_deg else 0
        z = self.z(value_deg)
        return 0 if not (math.isfinite(z) and abs(z) > Z_OUTSIDE) else (1 if z > 0 else -1)

    def band(self, k: float = Z_OUTSIDE) -> tuple[float, float] | None:
        """normal -+ k SD, None without an SD."""
        if not math.isfinite(self.sd_deg):
            return None
        return self.normal_deg - k * self.sd_deg, self.normal_deg + k * self.sd_deg


def key_norm(name: str, mean_deg, sd_deg, *, toe_off_pct: float = DEFAULT_TOE_OFF_PCT) -> KeyNorm:
    """The :class:`KeyNorm` of key value ``name`` on a band (mean and SD curves, 101 points, degrees)."""
    var_fn = KEY_VALUES.get(name)
    if var_fn is None:
        raise ValueError(f"unknown key value {name!r}; known: {', '.join(KEY_VALUES)}")
    mean, sd = np.asarray(mean_deg, dtype=np.float64), np.asarray(sd_deg, dtype=np.float64)
    if mean.shape != (101,) or sd.shape != (101,):
        raise ValueError(f"{name}: the band must have 101 points (0..100 % of the cycle), got {mean.shape}")
    toe = int(round(toe_off_pct))
    at = _point_of(name, mean, toe)
    normal = float(var_fn[1](mean, toe))
    if at is None:  # a range: the one-sided lower limit from the SDs where the mean curve peaks and dips
        spread = float(sd[int(np.argmax(mean))] + sd[int(np.argmin(mean))])
        return KeyNorm(name, normal, math.nan, None, max(0.0, normal - Z_OUTSIDE * spread))
    return KeyNorm(name, normal, float(sd[at]), at)


def key_norms(bands: Mapping[str, Mapping[str, Any]]) -> dict[str, KeyNorm]:
    """Key value name -> :class:`KeyNorm` for every key value whose variable has a band, except the values
    read at a point of an angle whose zero is not validated (:func:`no_reference`; its ranges of motion are
    kept) (``bands``: the ``kinematics.json`` ``norms.bands`` form, variable -> {"mean_deg", "sd_deg"})."""
    out = {}
    for name, (var, _) in KEY_VALUES.items():
        if no_reference(name):
            continue
        band = bands.get(var)
        if band and band.get("mean_deg") is not None and band.get("sd_deg") is not None:
            out[name] = key_norm(name, band["mean_deg"], band["sd_deg"])
    return out
