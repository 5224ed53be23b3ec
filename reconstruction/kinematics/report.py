"""The kinematics report of a trial: gait-cycle curves (mean +- SD per side), key clinical values, norms,
marker errors of the model fit. JSON-ready via :meth:`KinematicsReport.to_dict`, CSV via :func:`curves_csv`."""

from __future__ import annotations

import io
from dataclasses import dataclass, field

import numpy as np
from gaitcap.reconstruction.kinematics.angles import SIDES, VARIABLES, clinical_angles
from gaitcap.reconstruction.kinematics.clinical import key_values
from gaitcap.reconstruction.kinematics.cycles import (
    CYCLE_POINTS,
    CycleCurves,
    cycle_curves,
    cycles_from_steps,
)
from gaitcap.reconstruction.kinematics.norms import SOURCE, NormBand


def _list(a: np.ndarray) -> list[float | None]:
    return [None if not np.isfinite(v) else round(float(v), 2) for v in a]


@dataclass(frozen=True, eq=False)
class KinematicsReport:
    """curves: variable -> side -> CycleCurves; key_values: side -> name -> stats; norms: variable ->
    NormBand; marker_errors_mm: marker -> {"rms", "max"}; model: facts about the fit (engine, seconds...);
    warnings: what the fit could not do (a model coordinate resting on a bound of its range, ``bounds``)."""

    curves: dict[str, dict[str, CycleCurves]]
    key_values: dict[str, dict[str, dict]]
    norms: dict[str, NormBand] = field(default_factory=dict)
    marker_errors_mm: dict[str, dict[str, float]] = field(default_factory=dict)
    model: dict = field(default_factory=dict)
    not_measured: dict[str, str] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        curves = {var: {side: {"n_cycles": cc.n, "mean_deg": _list(cc.mean), "sd_deg": _list(cc.sd)}
                        for side, cc in by_side.items()} for var, by_side in self.curves.items()}
        return {
            "units": {"angles": "deg", "cycle": "% of gait cycle (0..100, 101 points)", "marker_errors": "mm"},
            "percent": list(range(CYCLE_POINTS)), "curves": curves, "key_values": self.key_values,
            "norms": {"source": SOURCE if self.norms else None,
                      "bands": {k: v.to_dict() for k, v in self.norms.items()}},
            "marker_errors_mm": self.marker_errors_mm, "model": self.model, "not_measured": self.not_measured,
            "warnings": list(self.warnings),
        }


def _col(values) -> np.ndarray:
    return np.array([np.nan if v is None else v for v in values], dtype=np.float64)


def curves_csv(d: dict) -> str:
    """The CSV of a report's JSON form (``curves``: variable -> side -> mean_deg / sd_deg; ``norms``:
    ``bands``: variable -> mean_deg / sd_deg, e.g. the band chosen for the patient): one row per % of the
    cycle, every variable's mean and SD per side, then its norm's mean and SD where there is a band."""
    bands = (d.get("norms") or {}).get("bands") or {}
    cols, data = ["percent"], [np.arange(CYCLE_POINTS, dtype=float)]
    for var, by_side in d.get("curves", {}).items():
        for side in SIDES:
            cols += [f"{var}_{side}_mean_deg", f"{var}_{side}_sd_deg"]
            data += [_col(by_side[side]["mean_deg"]), _col(by_side[side]["sd_deg"])]
        if var in bands:
            cols += [f"{var}_norm_mean_deg", f"{var}_norm_sd_deg"]
            data += [_col(bands[var]["mean_deg"]), _col(bands[var]["sd_deg"])]
    out = io.StringIO()
    out.write(",".join(cols) + "\n")
    for row in np.column_stack(data):
        out.write(",".join("" if not np.isfinite(v) else f"{v:.2f}" for v in row) + "\n")
    return out.getvalue()

def with_zero_offsets(angles: dict[str, dict[str, np.ndarray]], offsets_deg: dict[str, dict[str, float]]
                      ) -> dict[str, dict[str, np.ndarray]]:
    """``angles`` (variable -> side -> (T,) degrees) with each finite offset (degrees) added."""
    out = {}
    for var, by_side in angles.items():
        off = offsets_deg.get(var) or {}
        out[var] = {s: v + off[s] if np.isfinite(off.get(s, np.nan)) else v for s, v in by_side.items()}
    return out


def kinematics_report(coordinates_deg: dict[str, np.ndarray], times_s: np.ndarray, steps, *,
                      norms: dict[str, NormBand] | None = None, marker_errors_mm=None,
                      model: dict | None = None, held: dict[str, str] | None = None,
                      zero_offsets_deg: dict[str, dict[str, float]] | None = None,
                      warnings: list[str] | None = None) -> KinematicsReport:
    """Curves and key values from the model's coordinates (name -> (T,) degrees) and the gait report's
    steps (objects with foot, heel_strike_s, toe_off_s, pass_index). ``held``: coordinates the fit held
    rather than measured (-> why): the variables read from them get no curve and no key value, and
    ``not_measured`` says why. ``zero_offsets_deg``: variable -> side -> degrees added to the model's angle
    (the model's zero pose measured in the norm sources' joint-centre definitions, ``geometric``), so that
    a straight leg is 0 whatever the model calls 0; NaN or absent: the model's angle as it is. ``warnings``:
    sentences about the fit, kept as they are."""
    cycles = cycles_from_steps(steps)
    angles = with_zero_offsets(clinical_angles(coordinates_deg, times_s), zero_offsets_deg or {})
    not_measured = {var: (held or {})[coord] for var, v in VARIABLES.items() if var in angles
                    for coord in set(v.coordinate.values()) if coord in (held or {})}
    curves = {var: {side: cycle_curves(vals[side], times_s, cycles, side) for side in SIDES}
              for var, vals in angles.items() if var not in not_measured}
    keys = {side: key_values({var: curves[var][side] for var in curves}) for side in SIDES}
    return KinematicsReport(curves, keys, dict(norms or {}), dict(marker_errors_mm or {}), dict(model or {}),
                            not_measured, list(warnings or []))
