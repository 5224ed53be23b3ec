"""Joint angle curves of a trial against a reference model's (e.g. Plug-in-Gait), after time alignment.

For each variable and side the reference curve is sampled at the trial's frame times shifted by the lag
(``interp_nan``); over the frames where both are known: RMSE, the constant offset (mean of trial minus
reference: the models put their zeros in different places), the RMSE once the offset is removed, the
Pearson correlation, and the peak values (maximum and minimum of each curve over the same frames). Per
gait cycle (between consecutive reference heel strikes of that side, on the trial's clock): RMSE after
the whole trial's offset, and the correlation. Degrees throughout.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.validation.align import interp_nan


@dataclass(frozen=True)
class AngleAgreement:
    """One variable, one side (degrees): n frames compared, RMSE, offset (trial - reference), RMSE after
    the offset, r, peaks (max/min of trial and of reference), per-cycle (start s, RMSE after offset, r)."""

    variable: str
    side: str
    n: int
    rmse_deg: float
    offset_deg: float
    rmse_after_offset_deg: float
    r: float
    trial_max_deg: float
    trial_min_deg: float
    reference_max_deg: float
    reference_min_deg: float
    cycles: tuple[tuple[float, float, float], ...]


def _r(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.corrcoef(a, b)[0, 1]) if len(a) > 2 and a.std() > 0 and b.std() > 0 else float("nan")


def compare_angle(variable: str, side: str, trial_times_s: np.ndarray, trial_deg: np.ndarray,
                  ref_times_s: np.ndarray, ref_deg: np.ndarray, *, lag_s: float,
                  heel_strikes_s: np.ndarray = np.zeros(0)) -> AngleAgreement | None:
    """Agreement of one curve pair; None when fewer than 3 frames overlap. ``heel_strikes_s``: this
    side's reference heel strikes on the trial's clock (cycles)."""
    t = np.asarray(trial_times_s, float)
    a = np.asarray(trial_deg, float)
    b = interp_nan(t + lag_s, np.asarray(ref_times_s, float), np.asarray(ref_deg, float))
    ok = np.isfinite(a) & np.isfinite(b)
    if ok.sum() < 3:
        return None
    d = a[ok] - b[ok]
    offset = float(d.mean())
    cycles = []
    hs = np.sort(np.asarray(heel_strikes_s, float))
    for t0, t1 in zip(hs[:-1], hs[1:], strict=True):
        m = ok & (t >= t0) & (t < t1)
        if m.sum() >= 3:
            dc = a[m] - b[m] - offset
            cycles.append((float(t0), float(np.sqrt(np.mean(dc**2))), _r(a[m], b[m])))
    return AngleAgreement(variable, side, int(ok.sum()), float(np.sqrt(np.mean(d**2))), offset,
                          float(np.sqrt(np.mean((d - offset) ** 2))), _r(a[ok], b[ok]),
                          float(a[ok].max()), float(a[ok].min()), float(b[ok].max()), float(b[ok].min()),
                          tuple(cycles))
