"""Key clinical values of the gait-cycle curves (degrees), per cycle, then mean and SD per side."""

from __future__ import annotations

import math

import numpy as np
from gaitcap.reconstruction.kinematics.cycles import CycleCurves

DEFAULT_TOE_OFF_PCT = 60.0  # when the gait events give no toe-off for a cycle
TERMINAL_STANCE_FROM_PCT = 30.0


def _toe(pct: float) -> int:
    return int(round(pct if math.isfinite(pct) else DEFAULT_TOE_OFF_PCT))


def _per_cycle(curves: CycleCurves, fn) -> np.ndarray:
    return np.array([fn(c, _toe(p)) for c, p in zip(curves.curves, curves.toe_off_pct, strict=True)])


# value name -> (variable, function of (curve (101,), toe-off index) -> degrees)
KEY_VALUES = {
    "knee_flexion_initial_contact_deg": ("knee_flexion", lambda c, _to: c[0]),
    "knee_peak_flexion_swing_deg": ("knee_flexion", lambda c, to: c[to:].max()),
    "knee_flexion_rom_deg": ("knee_flexion", lambda c, _to: c.max() - c.min()),
    "ankle_peak_dorsiflexion_stance_deg": ("ankle_dorsiflexion", lambda c, to: c[: to + 1].max()),
    "ankle_minimum_deg": ("ankle_dorsiflexion", lambda c, _to: c.min()),
    "ankle_rom_deg": ("ankle_dorsiflexion", lambda c, _to: c.max() - c.min()),
    "hip_minimum_terminal_stance_deg": (
        "hip_flexion", lambda c, to: c[int(TERMINAL_STANCE_FROM_PCT): max(to, 31) + 1].min()),
    "hip_peak_flexion_deg": ("hip_flexion", lambda c, _to: c.max()),
    "hip_flexion_rom_deg": ("hip_flexion", lambda c, _to: c.max() - c.min()),
    "pelvis_tilt_rom_deg": ("pelvis_tilt", lambda c, _to: c.max() - c.min()),
    "pelvis_obliquity_rom_deg": ("pelvis_obliquity", lambda c, _to: c.max() - c.min()),
    "pelvis_rotation_rom_deg": ("pelvis_rotation", lambda c, _to: c.max() - c.min()),
    "hip_adduction_rom_deg": ("hip_adduction", lambda c, _to: c.max() - c.min()),
}

# value name -> how it is labelled, with the sign convention of its angle (every value keeps the curve's own
# sign: the ankle's minimum is its peak plantarflexion as a negative dorsiflexion, -10.8 "(dorsiflexion +)",
# the number the chart's curve reaches; the hip's peak extension likewise a negative flexion)
KEY_LABELS = {
    "knee_flexion_initial_contact_deg": "Knee flexion at initial contact (flexion +)",
    "knee_peak_flexion_swing_deg": "Knee peak flexion in swing (flexion +)",
    "knee_flexion_rom_deg": "Knee flexion range of motion",
    "ankle_peak_dorsiflexion_stance_deg": "Ankle peak in stance (dorsiflexion +)",
    "ankle_minimum_deg": "Ankle peak plantarflexion (dorsiflexion +)",
    "ankle_rom_deg": "Ankle range of motion",
    "hip_minimum_terminal_stance_deg": "Hip peak extension, late stance (flexion +)",
    "hip_peak_flexion_deg": "Hip peak flexion (flexion +)",
    "hip_flexion_rom_deg": "Hip flexion range of motion",
    "pelvis_tilt_rom_deg": "Pelvic tilt range of motion",
    "pelvis_obliquity_rom_deg": "Pelvic obliquity range of motion",
    "pelvis_rotation_rom_deg": "Pelvic rotation range of motion",
    "hip_adduction_rom_deg": "Hip adduction range of motion",
}


def key_label(name: str) -> str:
    """A key value's label with its sign convention (a name without one: the name in words)."""
    return KEY_LABELS.get(name) or name.removesuffix("_deg").replace("_", " ").capitalize()


def key_values(curves: dict[str, CycleCurves]) -> dict[str, dict[str, float | int | list | None]]:
    """value name -> {"mean", "sd", "n", "values"} over the cycles of one side (``curves``: variable ->
    curves); ``values``: the value of each cycle (degrees, in cycle order), what a finding's leave-one-out
    test reads (:func:`gaitcap.reconstruction.gait.stability.loo_mean_range`).

    Peak knee flexion in swing is the maximum after toe-off, ankle dorsiflexion in stance the maximum
    before it, the ankle's minimum its peak plantarflexion, the hip's minimum from 30 % to toe-off its peak
    extension in terminal stance; every value keeps its angle's sign (:data:`KEY_LABELS`: extension and
    plantarflexion are negative); toe-off from the gait events, 60 % when unknown."""
    out = {}
    for name, (var, fn) in KEY_VALUES.items():
        cc = curves.get(var)
        vals = _per_cycle(cc, fn) if cc is not None and cc.n else np.zeros(0)
        out[name] = {"mean": float(vals.mean()) if vals.size else None,
                     "sd": float(vals.std(ddof=1)) if vals.size > 1 else None, "n": int(vals.size),
                     "values": [float(v) for v in vals]}
    return out
