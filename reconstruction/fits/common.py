"""The fit problem shared by both trajectory representations."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.losses import Problem, make_observations
from gaitcap.reconstruction.projection import camera_arrays

SPAN_TOL_S = 1e-6


@dataclass(frozen=True, eq=False)
class FitOutput:
    """Attributes: points_mm (T, J, 3); history: loss per step; parts: final loss terms;
    trajectory: callable times_s (K,) -> (K, J, 3) mm, or None for discrete results."""

    points_mm: np.ndarray
    history: np.ndarray
    parts: dict[str, float]
    trajectory: object | None = None


def fit_problem(
    detections: MultiViewKeypoints, rig: Rig, weights: np.ndarray, *, gamma: float = 0.5
) -> Problem:
    """Observations weighted by ``weights`` (C, T, J) (robust weights or confidences), with views at
    or below confidence ``gamma`` given weight 0 (as the authors' code)."""
    conf = np.nan_to_num(detections.one_person[..., 2])
    w = np.where(conf > gamma, np.nan_to_num(weights), 0.0)
    skel = detections.skeleton
    limbs = np.array(skel.limb_indices, dtype=np.int32).reshape(-1, 2)
    return Problem(
        obs=make_observations(detections.one_person, w),
        cams=camera_arrays(rig.subset(detections.camera_names)),
        limb_a=jnp.asarray(limbs[:, 0]),
        limb_b=jnp.asarray(limbs[:, 1]),
    )


def reject_spikes(points_mm: np.ndarray, *, window: int = 9, min_mm: float = 80.0, mads: float = 5.0) -> np.ndarray:
    """Copy of points (T, J, 3) with temporal outliers set to NaN.

    A point is an outlier when it lies farther than max(``min_mm``, ``mads`` x 1.4826 x MAD) from the
    running median of its joint over ``window`` frames (MAD over that joint's distances). Used to clean
    the start of a fit: with two or three views a misdetection cannot be voted out per frame.
    """
    pts = np.array(points_mm, dtype=np.float64)
    t = pts.shape[0]
    if t < window:
        return pts
    half = window // 2
    padded = np.pad(pts, ((half, half), (0, 0), (0, 0)), mode="edge")
    win = np.lib.stride_tricks.sliding_window_view(padded, window, axis=0)  # (T, J, 3, W)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN windows
        med = np.nanmedian(win, axis=-1)
        dist = np.linalg.norm(pts - med, axis=-1)  # (T, J)
        mad = np.nanmedian(dist, axis=0, keepdims=True)
    limit = np.maximum(min_mm, mads * 1.4826 * np.nan_to_num(mad))
    pts[dist > limit] = np.nan
    return pts


def fill_gaps(points_mm: np.ndarray, times_s: np.ndarray, joint_names) -> np.ndarray:
    """Fill NaN frames of each joint by linear interpolation in time (ends held constant).

    Raises ValueError naming the joints that are never triangulated (nothing to fit them to).
    """
    pts = np.array(points_mm, dtype=np.float64)
    finite = np.isfinite(pts).all(-1)  # (T, J)
    never = [joint_names[j] for j in np.flatnonzero(~finite.any(0))]
    if never:
        raise ValueError(
            f"joints {never} have fewer than 2 usable views (confidence above the threshold) in every "
            "frame; cannot fit them (lower gamma or drop those joints)"
        )
    for j in np.flatnonzero(~finite.all(0)):
        ok = finite[:, j]
        for k in range(3):
            pts[:, j, k] = np.interp(times_s, times_s[ok], pts[ok, j, k])
    return pts


def to_fit_layout(points_mm: np.ndarray) -> jnp.ndarray:
    """(T, J, 3) -> (3, T, J) float32."""
    return jnp.asarray(np.transpose(points_mm, (2, 0, 1)), jnp.float32)


def from_fit_layout(points) -> np.ndarray:
    """(3, T, J) -> (T, J, 3) float64."""
    return np.transpose(np.asarray(points, dtype=np.float64), (1, 2, 0))


def check_span(times_s, t0: float, duration: float) -> np.ndarray:
    """times_s as a flat float array; ValueError if any is non-finite or outside [t0, t0 + duration] s."""
    t = np.asarray(times_s, dtype=np.float64).reshape(-1)
    if not np.all(np.isfinite(t)):
        raise ValueError("times_s: contains NaN or infinite values")
    lo, hi = t0 - SPAN_TOL_S, t0 + duration + SPAN_TOL_S
    outside = t[(t < lo) | (t > hi)]
    if outside.size:
        raise ValueError(
            f"times_s: {outside[0]:.4f} s is outside the fitted span [{t0:.4f}, {t0 + duration:.4f}] s"
        )
    return t
