"""The paper's trajectory losses in JAX: robust reprojection, smoothness, skeleton consistency.

Layout: a trajectory is ``points (3, T, J)`` in mm (coordinate axis first); observations are
cameras-first ``(C, T*J)`` arrays in the same (T, J) row-major order, so the projection is one matmul
(see :mod:`gaitcap.reconstruction.projection`) and no reduction runs over a leading camera axis.

- L_reproj: Huber of the per-keypoint reprojection distance (px), quadratic within ``delta`` (5 px),
  then linear; optionally the slope is cut to ``cut_factor`` (0.1) beyond ``cut_px`` (10 px, the
  paper's "MaxHuber=10"). Weighted mean over observations with weight > 0.
- L_smooth: mean over joints and frames of the per-frame displacement, mm/frame.
- L_skeleton: sqrt of the mean over limbs of the variance over time of the limb length, mm.
- L = L_reproj + 0.1 L_smooth + 0.1 L_skeleton.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np
from gaitcap.reconstruction.projection import CameraArrays, project

EPS_MM2 = 1e-6  # inside square roots, mm^2: keeps gradients finite at zero length


@dataclass(frozen=True)
class LossConfig:
    """Weights and robust-loss shape (defaults: the paper's)."""

    huber_delta_px: float = 5.0
    cut_px: float | None = None  # None: plain Huber; 10.0: the paper's "MaxHuber=10"
    cut_factor: float = 0.1
    smooth_weight: float = 0.1
    skeleton_weight: float = 0.1


class Observations(NamedTuple):
    """2D targets of a fit (a pytree). u_px, v_px, weight: (C, T*J); weight 0 = unused."""

    u_px: jnp.ndarray
    v_px: jnp.ndarray
    weight: jnp.ndarray


class Problem(NamedTuple):
    """Everything a loss evaluation needs besides the trajectory (pass it as a jit argument)."""

    obs: Observations
    cams: CameraArrays
    limb_a: jnp.ndarray  # (L,) joint indices
    limb_b: jnp.ndarray


def make_observations(keypoints: np.ndarray, weights: np.ndarray) -> Observations:
    """keypoints (C, T, J, 3) px/conf and weights (C, T, J) -> :class:`Observations` (NaN-free)."""
    c, t, j, _ = keypoints.shape
    kp = keypoints.reshape(c, t * j, 3)
    w = np.asarray(weights, dtype=np.float64).reshape(c, t * j)
    finite = np.isfinite(kp[..., :2]).all(-1) & np.isfinite(w)
    w = np.where(finite, w, 0.0)
    u = np.where(finite, kp[..., 0], 0.0)
    v = np.where(finite, kp[..., 1], 0.0)
    return Observations(jnp.asarray(u, jnp.float32), jnp.asarray(v, jnp.float32), jnp.asarray(w, jnp.float32))


def huber(sq_px2: jnp.ndarray, cfg: LossConfig) -> jnp.ndarray:
    """Huber of a distance given its square (px^2), with the optional slope cut."""
    delta = cfg.huber_delta_px
    inside = sq_px2 <= delta * delta
    d = jnp.sqrt(jnp.where(inside, delta * delta, sq_px2))  # safe sqrt: never evaluated at 0
    out = jnp.where(inside, 0.5 * sq_px2, delta * (d - 0.5 * delta))
    if cfg.cut_px is not None:
        cut = cfg.cut_px
        at_cut = delta * (cut - 0.5 * delta)
        out = jnp.where(d > cut, at_cut + cfg.cut_factor * delta * (d - cut), out)
    return out


def reprojection_sq_px2(points: jnp.ndarray, cams: CameraArrays, obs: Observations) -> jnp.ndarray:
    """Squared reprojection distances (C, T*J) px^2 of points (3, T, J) mm."""
    u, v = project(points.reshape(3, -1), cams)
    return (u - obs.u_px) ** 2 + (v - obs.v_px) ** 2


def reprojection_loss(points: jnp.ndarray, problem: Problem, cfg: LossConfig) -> jnp.ndarray:
    w = problem.obs.weight
    h = huber(reprojection_sq_px2(points, problem.cams, problem.obs), cfg)
    return jnp.sum(w * h) / jnp.maximum(jnp.sum(w), 1e-9)


def smooth_loss(points: jnp.ndarray) -> jnp.ndarray:
    """Mean per-frame displacement, mm/frame, of points (3, T, J)."""
    d = points[:, 1:] - points[:, :-1]
    return jnp.mean(jnp.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2 + EPS_MM2))


def limb_lengths(points: jnp.ndarray, limb_a: jnp.ndarray, limb_b: jnp.ndarray) -> jnp.ndarray:
    """Limb lengths (L, T) mm of points (3, T, J)."""
    d = points[:, :, limb_a] - points[:, :, limb_b]  # (3, T, L)
    return jnp.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2 + EPS_MM2).T


def skeleton_loss(points: jnp.ndarray, limb_a: jnp.ndarray, limb_b: jnp.ndarray) -> jnp.ndarray:
    """sqrt(mean over limbs of the variance over time of the limb length), mm (0 without limbs)."""
    if limb_a.shape[0] == 0:
        return jnp.zeros((), points.dtype)
    lengths = limb_lengths(points, limb_a, limb_b)
    var = jnp.mean((lengths - jnp.mean(lengths, axis=-1, keepdims=True)) ** 2, axis=-1)
    return jnp.sqrt(jnp.mean(var) + EPS_MM2)


def total_loss(points: jnp.ndarray, problem: Problem, cfg: LossConfig, reg_scale=1.0):
    """L = L_reproj + reg_scale * (0.1 L_smooth + 0.1 L_skeleton); returns (L, parts dict).

    ``reg_scale`` (0 or 1) switches the regularisers, as the paper's schedule does after 5000 steps.
    """
    rep = reprojection_loss(points, problem, cfg)
    smo = smooth_loss(points)
    ske = skeleton_loss(points, problem.limb_a, problem.limb_b)
    total = rep + reg_scale * (cfg.smooth_weight * smo + cfg.skeleton_weight * ske)
    return total, {"reproj": rep, "smooth": smo, "skeleton": ske}
