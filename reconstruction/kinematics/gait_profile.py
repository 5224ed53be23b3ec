"""Gait Profile Score and Gait Variable Scores (Baker R et al. The Gait Profile Score and Movement Analysis
Profile. Gait Posture 2009;30(3):265-269), against the normal band's mean curve.

GVS of one variable and side: the RMS difference (degrees) between the side's mean curve and the band's
mean curve at every 2 % of the cycle (51 points, 0-100 %). GPS of a side: the RMS of its GVS; overall: the
RMS of both sides' GVS. Baker's GPS uses nine variables (pelvic tilt, obliquity and rotation, hip
flexion, abduction and rotation, knee flexion, ankle dorsiflexion, foot progression); here only the
variables that are measured, validated and have a band enter, and the others are named (``not_included``)
with the reason, so a score over fewer variables is never read as Baker's full GPS. Pure computation.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from gaitcap.reconstruction.kinematics.key_norms import UNVALIDATED_COURSE, UNVALIDATED_ZERO

#: Baker 2009's nine variables, as this package names them (foot progression has no such angle here).
BAKER_VARIABLES = ("pelvis_tilt", "pelvis_obliquity", "pelvis_rotation", "hip_flexion", "hip_adduction",
                   "hip_rotation", "knee_flexion", "ankle_dorsiflexion", "foot_progression")
SAMPLES = np.arange(0, 101, 2)  # every 2 % of the cycle


@dataclass(frozen=True)
class GaitProfile:
    """GVS per side and variable (degrees), GPS per side and overall (degrees), and the variables of
    Baker's nine left out with why."""

    gvs_deg: dict[str, dict[str, float]]
    gps_deg: dict[str, float]
    overall_gps_deg: float
    not_included: dict[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"gvs_deg": {s: dict(v) for s, v in self.gvs_deg.items()}, "gps_deg": dict(self.gps_deg),
                "overall_gps_deg": self.overall_gps_deg, "variables": sorted({v for s in self.gvs_deg.values() for v in s}),
                "not_included": dict(self.not_included), "source": "Baker et al. 2009, Gait Posture 30(3):265-269"}


def _curve(values) -> np.ndarray | None:
    x = np.asarray([np.nan if v is None else v for v in (values or [])], dtype=np.float64)
    return x if x.shape == (101,) and np.isfinite(x[SAMPLES]).all() else None


def _rms(values) -> float:
    v = np.asarray(list(values), dtype=np.float64)
    return float(np.sqrt(np.mean(v**2))) if v.size else math.nan


def gait_profile(kinematics: Mapping[str, Any]) -> GaitProfile:
    """GVS and GPS of a ``kinematics.json`` dict with the band chosen for the patient (``curves``: variable
    -> side -> ``mean_deg`` (101,); ``norms.bands``: variable -> ``mean_deg``; ``not_measured``)."""
    curves, bands = kinematics.get("curves") or {}, (kinematics.get("norms") or {}).get("bands") or {}
    held = kinematics.get("not_measured") or {}
    gvs: dict[str, dict[str, float]] = {"left": {}, "right": {}}
    left_out = {}
    for var in BAKER_VARIABLES:
        band = _curve((bands.get(var) or {}).get("mean_deg"))
        if var in held:
            left_out[var] = f"not measured ({held[var]})"
            continue
        if var in UNVALIDATED_ZERO:
            left_out[var] = "zero not validated"
            continue
        if var in UNVALIDATED_COURSE:
            left_out[var] = f"not validated ({UNVALIDATED_COURSE[var]})"
            continue
        if var not in curves:
            left_out[var] = "not computed by this model"
            continue
        if band is None:
            left_out[var] = "no normal band for this patient"
            continue
        for side in gvs:
            mine = _curve(((curves.get(var) or {}).get(side) or {}).get("mean_deg"))
            if mine is not None:
                gvs[side][var] = _rms(mine[SAMPLES] - band[SAMPLES])
    gps = {side: _rms(v.values()) for side, v in gvs.items()}
    return GaitProfile(gvs, gps, _rms([x for v in gvs.values() for x in v.values()]), left_out)
