"""Time and space alignment of a trial with a reference recording of the same walk, found from the data.

Time: the lag ``lag_s`` with ``reference time = trial time + lag_s`` maximises the correlation of the two
heel heights (left with left, right with right, each side's mean removed), searched over every lag at
which at least ``min_overlap`` of the shorter recording overlaps the other (a reference longer than the
trial is the normal case), on the reference's frame grid, then refined to ``refine_step_s``. Walking is
periodic: the few best local maxima are kept and the one whose space fit leaves the smallest residual
wins (a lag a stride off puts the walker a stride away). The best correlation with the sides crossed is
reported too (left and right heels follow the same pattern half a stride apart, so it is high as well);
a swap of left and right shows in the space fit (``swap_sides``), as no proper rotation mirrors a walk.

Space: the rigid transform (rotation, translation; no scale) ``trial = R @ reference + t`` that fits the
reference's heel, ankle and hip markers, at the trial's frame times shifted by the lag, to gaitcap's
joints of the same names in the least-squares sense (Kabsch), refitted without the outliers (gaitcap's
frames where a joint was swapped or lost), with the RMS residual per joint. Marker
and joint centre differ (the ankle marker sits on the lateral malleolus, ~30-40 mm from the joint
centre), so a residual of a few centimetres is normal; a reference of another walk leaves hundreds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SIDES = ("left", "right")


@dataclass(frozen=True)
class AlignConfig:
    """min_overlap: fraction of the shorter recording that must overlap (0-1); min_correlation: the
    heel heights' correlation below which the recordings are not the same walk; max_residual_mm: the
    rigid fit's RMS residual above which the markers are not gaitcap's joints; refine_step_s: final lag
    resolution (s); candidates: lags (correlation peaks) tried by the space fit; outlier_factor,
    min_outlier_mm: a point farther than both (factor x the median distance, mm) is an outlier, refitted
    without; max_outlier_fraction: more outliers than this and the pair does not align."""

    min_overlap: float = 0.9
    min_correlation: float = 0.8
    max_residual_mm: float = 35.0
    refine_step_s: float = 0.001
    candidates: int = 5
    outlier_factor: float = 3.0
    min_outlier_mm: float = 50.0
    max_outlier_fraction: float = 0.1


def swap_sides(joints: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The same joints with left and right exchanged."""
    flip = {"left": "right", "right": "left"}
    return {flip[n.split("_", 1)[0]] + "_" + n.split("_", 1)[1] if n.split("_", 1)[0] in flip else n: p
            for n, p in joints.items()}


class AlignmentError(ValueError):
    """The pair does not align; the message names what did not match."""


@dataclass(frozen=True)
class TimeAlignment:
    """lag_s: reference time = trial time + lag_s; correlation: of the heel heights at that lag (0-1);
    crossed_correlation: the best with left and right crossed; overlap_s: overlapping span (s);
    residual_mm: RMS difference of the heel heights at the lag after each side's mean (mm)."""

    lag_s: float
    correlation: float
    crossed_correlation: float
    overlap_s: float
    residual_mm: float


@dataclass(frozen=True)
class SpaceAlignment:
    """trial = rotation @ reference + translation_mm (mm); residual_mm: RMS over the points kept; joint_residual_mm:
    per joint RMS (kept points); points: number of points kept; joints: the joints used; outlier_fraction: the
    points left out as outliers (0-1)."""

    rotation: np.ndarray
    translation_mm: np.ndarray
    residual_mm: float
    joint_residual_mm: dict[str, float]
    points: int
    joints: tuple[str, ...]
    outlier_fraction: float = 0.0

    def apply(self, points_mm: np.ndarray) -> np.ndarray:
        """(..., 3) reference-frame points (mm) -> the trial's frame (mm)."""
        return np.asarray(points_mm) @ self.rotation.T + self.translation_mm

    @property
    def rotation_deg(self) -> float:
        """Angle of the rotation (degrees)."""
        return float(np.degrees(np.arccos(np.clip((np.trace(self.rotation) - 1) / 2, -1.0, 1.0))))


def interp_nan(t_query: np.ndarray, t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(Q,) or (Q, D) linear interpolation of (T,) or (T, D) ``y`` at ``t_query``; NaN outside ``t`` or
    next to a NaN sample."""
    y = np.asarray(y, dtype=np.float64)
    flat = y.reshape(len(t), -1)
    out = np.full((len(t_query), flat.shape[1]), np.nan)
    inside = (t_query >= t[0]) & (t_query <= t[-1])
    for d in range(flat.shape[1]):
        col = flat[:, d]
        ok = np.isfinite(col)
        if ok.sum() < 2:
            continue
        v = np.interp(t_query[inside], t[ok], col[ok])
        # a query between two samples of which one is missing stays missing
        k = np.clip(np.searchsorted(t, t_query[inside]), 1, len(t) - 1)
        v[~(ok[k] & ok[k - 1])] = np.nan
        out[inside, d] = v
    return out.reshape((len(t_query), *y.shape[1:]))


def _score(trial_t, trial_h, ref_t, ref_h, lag: float, min_samples: int) -> tuple[float, float, int]:
    """(correlation, RMS residual mm, samples) of trial heel heights vs reference ones at ``lag``."""
    xs, ys = [], []
    for a, b in zip(trial_h, ref_h, strict=True):
        r = interp_nan(trial_t + lag, ref_t, b)
        ok = np.isfinite(a) & np.isfinite(r)
        if ok.sum() < 3:
            return -1.0, np.inf, 0
        xs.append(a[ok] - a[ok].mean())
        ys.append(r[ok] - r[ok].mean())
    x, y = np.concatenate(xs), np.concatenate(ys)
    if len(x) < min_samples:
        return -1.0, np.inf, len(x)
    denom = np.sqrt((x @ x) * (y @ y))
    corr = float(x @ y / denom) if denom > 0 else -1.0
    return corr, float(np.sqrt(np.mean((x - y) ** 2))), len(x)


def _best(trial_t, trial_h, ref_t, ref_h, lags, min_samples) -> tuple[float, float, float]:
    scores = [_score(trial_t, trial_h, ref_t, ref_h, lag, min_samples) for lag in lags]
    k = int(np.argmax([s[0] for s in scores]))
    return float(lags[k]), scores[k][0], scores[k][1]


def _peaks(corr: np.ndarray, k: int) -> np.ndarray:
    """Indices of the k highest local maxima of ``corr`` (highest first)."""
    c = np.r_[-np.inf, corr, -np.inf]
    idx = np.flatnonzero((c[1:-1] >= c[:-2]) & (c[1:-1] >= c[2:]) & np.isfinite(corr))
    return idx[np.argsort(-corr[idx])][:k]


def find_lag(trial_times_s: np.ndarray, trial_heel_mm: dict[str, np.ndarray], ref_times_s: np.ndarray,
             ref_heel_mm: dict[str, np.ndarray], *, config: AlignConfig = AlignConfig()) -> list[TimeAlignment]:
    """Candidate lags from heel heights, best correlation first: ``trial_heel_mm`` / ``ref_heel_mm``: side ->
    (T,) / (R,) heel height (mm, up positive; any constant offset). Walking is periodic, so a lag a stride
    away can correlate nearly as well: every local maximum above ``min_correlation`` is a candidate (at most
    ``candidates``), for the space fit to choose from. Raises :class:`AlignmentError` naming what did not
    match."""
    trial_t, ref_t = np.asarray(trial_times_s, float), np.asarray(ref_times_s, float)
    dur_trial, dur_ref = trial_t[-1] - trial_t[0], ref_t[-1] - ref_t[0]
    need = config.min_overlap * min(dur_trial, dur_ref)
    lo, hi = ref_t[0] - trial_t[-1] + need, ref_t[-1] - trial_t[0] - need
    if hi < lo:
        raise AlignmentError("time: the recordings are too short to overlap")
    step = float(np.median(np.diff(ref_t)))
    lags = np.arange(lo, hi + step / 2, step)
    min_samples = int(config.min_overlap * min(len(trial_t), dur_ref / np.median(np.diff(trial_t))))
    a = [np.asarray(trial_heel_mm[s], float) for s in SIDES]
    b = [np.asarray(ref_heel_mm[s], float) for s in SIDES]
    corr = np.array([_score(trial_t, a, ref_t, b, lag, min_samples)[0] for lag in lags])
    _, crossed, _ = _best(trial_t, a, ref_t, b[::-1], lags, min_samples)
    out = []
    for k in _peaks(corr, config.candidates):
        if corr[k] < config.min_correlation and out:
            break
        fine = np.arange(lags[k] - step, lags[k] + step + 1e-12, config.refine_step_s)
        lag, c, resid = _best(trial_t, a, ref_t, b, fine, min_samples)
        overlap = min(trial_t[-1] + lag, ref_t[-1]) - max(trial_t[0] + lag, ref_t[0])
        out.append(TimeAlignment(lag, c, crossed, float(overlap), resid))
    best = out[0] if out else TimeAlignment(float("nan"), -1.0, crossed, 0.0, float("nan"))
    if best.correlation < config.min_correlation:
        raise AlignmentError(f"time: the heel heights match at no lag (best correlation {best.correlation:.2f} "
                             f"at {best.lag_s:+.2f} s, below {config.min_correlation}): the reference is not this walk")
    return out


def fit_rigid(reference_mm: np.ndarray, trial_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(R (3, 3), t (3,)) minimising ||R @ reference + t - trial|| over (N, 3) point pairs (Kabsch, a proper
    rotation)."""
    mu_r, mu_t = reference_mm.mean(axis=0), trial_mm.mean(axis=0)
    h = (reference_mm - mu_r).T @ (trial_mm - mu_t)
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    rot = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return rot, mu_t - rot @ mu_r


def align_space(trial_times_s: np.ndarray, trial_joints_mm: dict[str, np.ndarray], ref_times_s: np.ndarray,
                ref_joints_mm: dict[str, np.ndarray], lag_s: float, *, joints: tuple[str, ...],
                config: AlignConfig = AlignConfig()) -> SpaceAlignment:
    """The rigid fit of the reference's ``joints`` (names present in both) at ``trial time + lag_s`` to the
    trial's; raises :class:`AlignmentError` naming the joint that fits worst when the residual is too big."""
    names = tuple(n for n in joints if n in trial_joints_mm and n in ref_joints_mm)
    if len(names) < 2:
        raise AlignmentError(f"space: fewer than 2 of the joints {', '.join(joints)} are in both recordings")
    src, dst, owner = [], [], []
    for n in names:
        r = interp_nan(np.asarray(trial_times_s) + lag_s, ref_times_s, ref_joints_mm[n])
        ok = np.isfinite(r).all(axis=1) & np.isfinite(trial_joints_mm[n]).all(axis=1)
        src.append(r[ok])
        dst.append(np.asarray(trial_joints_mm[n])[ok])
        owner += [n] * int(ok.sum())
    src, dst, owner = np.concatenate(src), np.concatenate(dst), np.array(owner)
    if len(src) < 6:
        raise AlignmentError("space: fewer than 6 marker positions overlap the trial in time")
    keep = np.ones(len(src), bool)
    for _ in range(5):  # gaitcap's outlier frames (a swapped or lost joint) must not bend the fit
        rot, t = fit_rigid(src[keep], dst[keep])
        err = np.linalg.norm(src @ rot.T + t - dst, axis=1)
        new = err <= max(config.outlier_factor * float(np.median(err)), config.min_outlier_mm)
        if (new == keep).all() or new.sum() < 6:
            break
        keep = new
    per = {n: float(np.sqrt(np.mean(err[(owner == n) & keep] ** 2))) if ((owner == n) & keep).any() else float("nan")
           for n in names}
    rms = float(np.sqrt(np.mean(err[keep] ** 2)))
    outliers = float(1.0 - keep.mean())
    if rms > config.max_residual_mm or outliers > config.max_outlier_fraction:
        worst = max(per, key=lambda n: per[n] if np.isfinite(per[n]) else np.inf)
        raise AlignmentError(f"space: the reference's markers do not fit gaitcap's joints (RMS residual "
                             f"{rms:.0f} mm over {100 * (1 - outliers):.0f} % of the points, limits "
                             f"{config.max_residual_mm:.0f} mm and {100 * (1 - config.max_outlier_fraction):.0f} %; "
                             f"worst {worst} {per[worst]:.0f} mm): not the same walk, or a marker is mislabelled")
    return SpaceAlignment(rot, t, rms, per, int(keep.sum()), names, outliers)
