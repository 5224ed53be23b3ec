"""The hand-held board's motion in a calibration: webcams are not hardware-synchronised, so a frame set's
views are exposed at slightly different instants, and a board moving fast is smeared (motion blur,
rolling shutter). Each corner's image velocity (px/s) comes from its own camera's neighbouring views in
time; then, after the first bundle adjustment:

- each view's mean squared residual is modelled as ``2 s0^2 + (k |v|)^2`` (|v| its corners' mean
  speed, ``s0`` a still board's error per axis, ``k`` the smear time, s): its corners then weigh
  ``2 s0^2 / (2 s0^2 + (k |v|)^2)``, so fast views count less instead of pulling the cameras towards their
  smeared corners;
- each camera but the root gets a time offset ``d`` (s), adjusted in the bundle adjustment run again
  with the rest (a corner is seen where the board was ``d`` after the frame set's instant: projected +
  ``v d``); reported relative to the root camera with a standard error.

Nothing is done where the views' neighbours are too far apart in time to tell a velocity (``max_gap_s``),
and the report says so. Pure computation.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from gaitcap.reconstruction.calibration.geometry import BoardObservations


@dataclass(frozen=True)
class MotionConfig:
    """How the board's motion is modelled.

    Attributes:
        max_gap_s: a corner's velocity comes from its camera's views at most this far apart in time (s);
            farther neighbours say nothing about the motion at the frame.
        min_corners: a camera needs at least this many corners with a velocity for its time offset to
            be adjusted (else every offset stays 0, said in the report).
        min_views: the noise model needs at least this many views with a speed.
        significance: the errors' growth with speed is modelled only where it exceeds this many of its
            standard errors.
        offsets: adjust the cameras' time offsets (False: the views are only weighted).
    """

    max_gap_s: float = 0.25
    min_corners: int = 100
    min_views: int = 10
    significance: float = 3.0
    offsets: bool = True


@dataclass(frozen=True)
class MotionReport:
    """What the board's motion did to a calibration: per camera (``cameras`` order) its time offset after
    the root camera's (``root``) and its standard error (ms; NaN: not adjusted); the noise model
    (``sigma0_px``: a still board's corner error per axis, ``smear_ms``: the smear time k; NaN when not
    fitted), the views with a speed and the smallest weight given; notes in plain words."""

    cameras: tuple[str, ...]
    root: str
    offsets_ms: tuple[float, ...]
    offsets_se_ms: tuple[float, ...]
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
    vel = np.full(obs.corners_px.shape, np.nan)
    t = obs.times_s
    for c in range(obs.shape[0]):
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


@dataclass(frozen=True, eq=False)
class SpeedWeights:
    """Each corner's weight (P,) from the noise model, its parameters (NaN: not fitted) and the views with
    a speed."""

    weight: np.ndarray
    sigma0_px: float
    smear_s: float
    views_with_speed: int


def speed_weights(*, cam: np.ndarray, frame: np.ndarray, residual_px: np.ndarray, inlier: np.ndarray,
                  velocity_px_s: np.ndarray, config: MotionConfig) -> SpeedWeights:
    """Fit ``mean |e|^2 = 2 s0^2 + (k |v|)^2`` over the views (P rows: camera, frame, residual px, inlier,
    velocity px/s, NaN unknown) and weigh each corner by ``2 s0^2 / (2 s0^2 + (k |v|)^2)`` of its view (a
    view without a speed: the median view's); all 1 where too few views have a speed or the errors do
    not grow with it beyond ``significance`` standard errors."""
    keys, inv = np.unique(np.stack([cam, frame], 1), axis=0, return_inverse=True)
    inv = inv.ravel()
    ok = inlier
    msq = np.bincount(inv[ok], np.sum(residual_px[ok] ** 2, -1), minlength=len(keys))
    msq = msq / np.maximum(np.bincount(inv[ok], minlength=len(keys)), 1)
    speed = np.linalg.norm(velocity_px_s, axis=-1)
    has = ok & np.isfinite(speed)
    counts = np.bincount(inv[has], minlength=len(keys))
    sp = np.where(counts > 0, np.bincount(inv[has], speed[has], minlength=len(keys)) / np.maximum(counts, 1), np.nan)
    good = np.isfinite(sp)
    none = SpeedWeights(np.ones(len(cam)), float("nan"), float("nan"), int(good.sum()))
    if good.sum() < config.min_views:
        return none
    a = np.stack([np.ones(good.sum()), sp[good] ** 2], 1)
    (c0, c1), *_ = np.linalg.lstsq(a, msq[good], rcond=None)
    resid = msq[good] - a @ [c0, c1]
    cov = np.linalg.pinv(a.T @ a) * float(resid @ resid) / max(len(resid) - 2, 1)
    if not (c0 > 0 and c1 > config.significance * np.sqrt(max(cov[1, 1], 0.0))):
        return none
    view_sp = np.where(good, sp, np.nanmedian(sp))
    view_w = c0 / (c0 + c1 * view_sp**2)
    return SpeedWeights(view_w[inv], float(np.sqrt(c0 / 2)), float(np.sqrt(c1)), int(good.sum()))


def offset_errors(*, cam: np.ndarray, residual_px: np.ndarray, inlier: np.ndarray, velocity_px_s: np.ndarray,
                  weight: np.ndarray, n_cams: int) -> np.ndarray:
    """(C,) each camera's time offset's standard error (s) from its inlier corners' weighted residuals
    (px) and velocities (px/s, 0 unknown): sqrt(sigma^2 / sum w |v|^2) (NaN: no velocity)."""
    se = np.full(n_cams, np.nan)
    for c in range(n_cams):
        m = inlier & (cam == c)
        vv = float(np.sum(weight[m, None] * velocity_px_s[m] ** 2))
        if vv > 0:
            var = float(np.sum(weight[m, None] * residual_px[m] ** 2)) / max(2 * m.sum() - 1, 1)
            se[c] = np.sqrt(var / vv)
    return se


def motion_report(names, root: int, offsets_s: np.ndarray | None, se_s: np.ndarray, weights: SpeedWeights,
                  config: MotionConfig, why_not: str = "") -> MotionReport:
    """The report of what the motion model did (``offsets_s`` None: not adjusted, ``why_not`` says why)."""
    notes = []
    if np.isfinite(weights.smear_s):
        notes.append(f"views weighted by the board's speed: corner error {weights.sigma0_px:.2f} px per axis at "
                     f"rest, growing by {1e3 * weights.smear_s:.1f} ms x the corners' speed (weights "
                     f"{weights.weight.min():.2f}-{weights.weight.max():.2f})")
    elif weights.views_with_speed < config.min_views:
        notes.append(f"the board's motion not modelled: {weights.views_with_speed} views have a neighbouring view "
                     f"of their camera within {1e3 * config.max_gap_s:.0f} ms (need {config.min_views})")
    else:
        notes.append("the board's speed did not raise the views' errors: every view weighs the same")
    if offsets_s is None:
        offsets = se = (float("nan"),) * len(names)
        if why_not:
            notes.append(why_not)
    else:
        offsets = tuple(float(1e3 * d) for d in offsets_s)
        se = tuple(0.0 if c == root else float(1e3 * e) for c, e in enumerate(se_s))
        named = [f"{n} {d:+.1f} +- {e:.1f} ms" for c, (n, d, e) in enumerate(zip(names, offsets, se, strict=True))
                 if c != root]
        notes.append(f"time offsets from the board's motion, after {names[root]}: {', '.join(named)}")
    return MotionReport(tuple(names), names[root], offsets, se, weights.sigma0_px,
                        1e3 * weights.smear_s if np.isfinite(weights.smear_s) else float("nan"),
                        weights.views_with_speed, float(weights.weight.min()), tuple(notes))
