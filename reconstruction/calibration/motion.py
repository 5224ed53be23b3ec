"""The hand-held board's motion in a calibration: webcams are not hardware-synchronised, so a frame set's
views are exposed at slightly different instants, and a board moving fast is smeared (motion blur,
rolling shutter). Both show in the first bundle adjustment's residuals, against each corner's image
velocity (px/s, from its own camera's neighbouring views):

- a camera exposed ``d`` s after the frame set's instant sees each corner moved by ``v d``: its offset is
  the least-squares ``d`` of the residuals (e = projected - observed ~ -v d); the common part of the
  offsets is absorbed by the board poses, so they are reported relative to their precision-weighted
  mean, each with its standard error; an offset beyond ``significance`` standard errors is applied (the
  camera's corners moved back to the frame set's instant: ``uv - v d``), the others are not;
- each view's mean squared residual is modelled as ``s0^2 + (k |v|)^2`` (|v| its median corner speed,
  ``k`` the smear time, s): its corners then weigh ``s0^2 / (s0^2 + (k |v|)^2)`` in the adjustment run
  again, so fast views count less instead of pulling the cameras towards their smeared corners.

Nothing is done where the views' neighbours are too far apart in time to tell a velocity (``max_gap_s``),
and the report says so. Pure computation on the flattened bundle problem.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np
from gaitcap.reconstruction.calibration.geometry import BoardObservations


@dataclass(frozen=True)
class MotionConfig:
    """How the board's motion is modelled.

    Attributes:
        max_gap_s: a corner's velocity comes from its camera's views at most this far apart in time (s);
            farther neighbours say nothing about the motion at the frame.
        significance: an offset is applied when it exceeds this many standard errors.
        min_corners: a camera needs at least this many corners with a velocity for an offset.
        min_views: the noise model needs at least this many views with a speed.
    """

    max_gap_s: float = 0.25
    significance: float = 3.0
    min_corners: int = 100
    min_views: int = 10


@dataclass(frozen=True)
class MotionReport:
    """What the board's motion did to a calibration: per camera (``cameras`` order) its time offset and
    standard error (ms, relative to the cameras' weighted mean; NaN: not estimated) and whether it was
    applied; the noise model (``sigma0_px``: the error of a still board's corner, ``smear_ms``: the
    smear time k; NaN when not fitted), the views with a speed and the weight range given; notes in
    plain words."""

    cameras: tuple[str, ...]
    offsets_ms: tuple[float, ...]
    offsets_se_ms: tuple[float, ...]
    applied: tuple[bool, ...]
    sigma0_px: float
    smear_ms: float
    views_with_speed: int
    min_weight: float
    notes: tuple[str, ...]

    def to_dict(self) -> dict:
        return asdict(self)


def corner_velocities(obs: BoardObservations, max_gap_s: float) -> np.ndarray:
    """(C, F, N, 2) each observed corner's image velocity (px/s) from its camera's neighbouring views
    in time (a central difference where both neighbours lie within ``max_gap_s``, else the nearer
    one-sided one; NaN where neither does or the corner is not seen in them)."""
    c_n, f_n = obs.shape[:2]
    vel = np.full(obs.corners_px.shape, np.nan)
    t = obs.times_s
    for c in range(c_n):
        seen = np.flatnonzero(np.isfinite(obs.corners_px[c]).all(-1).any(-1))
        seen = seen[np.argsort(t[seen], kind="stable")]
        for j, f in enumerate(seen):
            before = seen[j - 1] if j > 0 else None
            after = seen[j + 1] if j + 1 < len(seen) else None
            for a, b in ((before, after), (f, after), (before, f)):  # best first; NaNs filled by the next
                if a is None or b is None or t[b] - t[a] <= 0 or max(t[b] - t[f], t[f] - t[a]) > max_gap_s:
                    continue
                v = (obs.corners_px[c, b] - obs.corners_px[c, a]) / (t[b] - t[a])
                fill = np.isnan(vel[c, f]).any(-1) & np.isfinite(v).all(-1)
                vel[c, f][fill] = v[fill]
    return vel


def _offsets(cam, err, vel, ok, n_cams: int, config: MotionConfig):
    """Per camera the least-squares offset (s) of residuals ``err`` (P, 2) against velocities (P, 2)
    over rows ``ok``, its standard error, relative to the precision-weighted mean (NaN: too few)."""
    d, se = np.full(n_cams, np.nan), np.full(n_cams, np.nan)
    for c in range(n_cams):
        m = ok & (cam == c)
        vv = float(np.sum(vel[m] ** 2))
        if m.sum() < config.min_corners or vv <= 0:
            continue
        d[c] = -float(np.sum(err[m] * vel[m])) / vv
        resid = err[m] + vel[m] * d[c]
        se[c] = float(np.sqrt(np.sum(resid**2) / max(2 * m.sum() - 1, 1) / vv))
    fin = np.isfinite(d)
    if fin.sum() >= 2:
        d[fin] -= np.average(d[fin], weights=1 / se[fin] ** 2)
    else:
        d[:] = np.nan
    return d, se


def _noise_model(cam, frame, err, speed, ok, config: MotionConfig) -> tuple[float, float, np.ndarray, np.ndarray]:
    """Fit ``mean |e|^2 = 2 s0^2 + (k |v|)^2`` over views: (s0 px, k s, view keys (V, 2), view speeds (V,));
    NaN where too few views or no growth with speed."""
    keys, inv = np.unique(np.stack([cam[ok], frame[ok]], 1), axis=0, return_inverse=True)
    inv = inv.ravel()
    msq = np.bincount(inv, np.sum(err[ok] ** 2, -1)) / np.bincount(inv)
    sp = np.full(len(keys), np.nan)
    has = np.isfinite(speed[ok])
    if has.any():
        sums = np.bincount(inv[has], speed[ok][has], minlength=len(keys))
        counts = np.bincount(inv[has], minlength=len(keys))
        sp = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)
    good = np.isfinite(sp)
    if good.sum() < config.min_views:
        return float("nan"), float("nan"), keys, sp
    a = np.stack([np.ones(good.sum()), sp[good] ** 2], 1)
    (c0, c1), *_ = np.linalg.lstsq(a, msq[good], rcond=None)
    if not (c0 > 0 and c1 > 0):
        return float("nan"), float("nan"), keys, sp
    return float(np.sqrt(c0 / 2)), float(np.sqrt(c1)), keys, sp


def motion_model(*, cam: np.ndarray, frame: np.ndarray, uv_px: np.ndarray, residual_px: np.ndarray,
                 inlier: np.ndarray, velocity_px_s: np.ndarray, camera_names, config: MotionConfig,
                 ) -> tuple[np.ndarray, np.ndarray, MotionReport]:
    """From a fit's flattened corners (P rows: camera, frame, observed px, residual px = projected -
    observed, inlier flag) and their image velocities (P, 2) px/s (NaN: unknown): the corners moved to
    their frame set's instant by the significant offsets (P, 2) px, each corner's weight (P,), and the
    report."""
    n_cams = len(camera_names)
    ok = inlier & np.isfinite(velocity_px_s).all(-1)
    vel = np.where(np.isfinite(velocity_px_s), velocity_px_s, 0.0)
    d, se = _offsets(cam, residual_px, vel, ok, n_cams, config)
    applied = np.isfinite(d) & (np.abs(d) > config.significance * se)
    shift = np.where(applied[cam], d[cam], 0.0)[:, None] * vel
    corrected = uv_px - shift
    err = residual_px + shift  # the residuals with the offsets applied, the poses as fitted
    speed = np.linalg.norm(velocity_px_s, axis=-1)
    s0, k, keys, sp = _noise_model(cam, frame, err, speed, inlier, config)
    notes = []
    weight = np.ones(len(cam))
    if np.isfinite(k):
        view_sp = np.where(np.isfinite(sp), sp, np.nanmedian(sp))
        view_w = (2 * s0**2) / (2 * s0**2 + (k * view_sp) ** 2)
        lookup = {(int(a), int(b)): w for (a, b), w in zip(keys, view_w, strict=True)}
        weight = np.array([lookup.get((int(a), int(b)), 1.0) for a, b in zip(cam, frame, strict=True)])
        notes.append(f"views weighted by the board's speed: error {s0:.2f} px per axis at rest, growing by "
                     f"{1e3 * k:.1f} ms x the corners' speed (weights {weight.min():.2f}-{weight.max():.2f})")
    elif int(np.isfinite(sp).sum()) < config.min_views:
        notes.append(f"the board's motion not modelled: {int(np.isfinite(sp).sum())} views have a neighbouring "
                     f"view of their camera within {1e3 * config.max_gap_s:.0f} ms (need {config.min_views})")
    else:
        notes.append("the board's speed did not raise the views' errors: every view weighs the same")
    named = [f"{n} {1e3 * a:+.1f} +- {1e3 * b:.1f} ms" for n, a, b in zip(camera_names, d, se, strict=True)
             if np.isfinite(a)]
    if named:
        used = [n for n, a in zip(camera_names, applied, strict=True) if a]
        notes.append(f"time offsets from the board's motion: {', '.join(named)}; "
                     + (f"applied to {', '.join(used)}" if used else
                        f"none beyond {config.significance:g} standard errors, none applied"))
    report = MotionReport(tuple(camera_names), tuple(float(1e3 * x) for x in d), tuple(float(1e3 * x) for x in se),
                          tuple(bool(a) for a in applied), s0, 1e3 * k if np.isfinite(k) else float("nan"),
                          int(np.isfinite(sp).sum()), float(weight.min()), tuple(notes))
    return corrected, weight, report


def with_motion(prob, corrected_px: np.ndarray, weight: np.ndarray):
    """The bundle problem with its corners moved and weighted (:func:`motion_model`)."""
    return replace(prob, uv_px=corrected_px, weight=weight)
