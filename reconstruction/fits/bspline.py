"""Local-support time model for the implicit fit: uniform cubic B-splines with knots at the band limit.

A trajectory is ``x(t) = sum_k B_k(t) w_k``: each frame depends on the 4 control points around it, so
the model's cost (evaluation, gradient, memory) grows linearly with the trial, and the least-squares
start is a banded system (bandwidth 3) solved in O(K) instead of the O(F^3) dense solve of a global
basis. Knots are ``knot_spacing_s = 1 / (knots_per_cycle x max_freq_hz)`` apart (rounded so that they
land on both ends of the trial); a cubic spline with that spacing passes motion up to about
``max_freq_hz`` and cannot represent faster jitter, as the Fourier basis cannot.

The start is penalised least squares on the second differences of the control points (a P-spline):
it keeps the system well posed where frames are sparse (low frame rates, gaps) without pulling positions
towards zero as a plain ridge would.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np
import scipy.linalg
import scipy.sparse
from gaitcap.reconstruction.fits.common import check_span

MM_PER_M = 1000.0
ORDER = 4  # cubic: 4 control points per frame


def cubic_weights(s: np.ndarray) -> np.ndarray:
    """Uniform cubic B-spline weights (K, 4) at fractions ``s`` (K,) in [0, 1] of a knot interval."""
    s = np.asarray(s, dtype=np.float64)
    s2, s3 = s * s, s * s * s
    return np.stack(
        [(1 - s) ** 3 / 6, (3 * s3 - 6 * s2 + 4) / 6, (-3 * s3 + 3 * s2 + 3 * s + 1) / 6, s3 / 6], -1
    )


@dataclass(frozen=True)
class BSplineBasis:
    """Cubic B-spline time model.

    Attributes:
        max_freq_hz: band limit, Hz; sets the knot spacing with ``knots_per_cycle``.
        knots_per_cycle: knots per period of ``max_freq_hz`` (2: the Nyquist spacing).
        smooth_penalty: weight of the second-difference penalty of the least-squares start, relative
            to the mean diagonal of B^T B.
    """

    max_freq_hz: float = 8.0
    knots_per_cycle: float = 2.0
    smooth_penalty: float = 1e-3

    def __post_init__(self) -> None:
        if not self.max_freq_hz > 0:
            raise ValueError(f"max_freq_hz: must be > 0 Hz, got {self.max_freq_hz}")
        if not self.knots_per_cycle > 0:
            raise ValueError(f"knots_per_cycle: must be > 0, got {self.knots_per_cycle}")

    def intervals(self, duration_s: float) -> int:
        """Number of knot intervals over a trial of ``duration_s`` s (at least 1)."""
        return max(int(math.ceil(duration_s * self.knots_per_cycle * self.max_freq_hz - 1e-9)), 1)

    def model_bytes(self, frames: int, duration_s: float, joints: int) -> int:
        """Bytes of the model's own arrays in a fit: per-frame features and the float32 control points
        with the solver's copies of them (L-BFGS keeps 20), linear in the trial."""
        return 32 * frames + 4 * 32 * (self.intervals(duration_s) + ORDER - 1) * 3 * joints

    def locate(self, times_s: np.ndarray, t0: float, duration: float) -> tuple[np.ndarray, np.ndarray]:
        """(K,) s -> first control point index (K,) int and weights (K, 4) of each time."""
        n = self.intervals(duration)
        u = (np.asarray(times_s, dtype=np.float64) - t0) / duration * n
        first = np.clip(np.floor(u), 0, n - 1).astype(np.int32)
        return first, cubic_weights(np.clip(u - first, 0.0, 1.0))

    def init(self, times_s: np.ndarray, init_mm: np.ndarray, key):
        """Control points (n + 3, 3J) m fitted to ``init_mm`` (T, J, 3), the frames' features, span."""
        t0, duration = float(times_s[0]), max(float(times_s[-1] - times_s[0]), 1e-3)
        first, w = self.locate(times_s, t0, duration)
        n_ctrl = self.intervals(duration) + ORDER - 1
        t, j, _ = init_mm.shape
        target = np.transpose(init_mm, (0, 2, 1)).reshape(t, 3 * j) / MM_PER_M  # (T, 3J), column k*J + j
        weights = banded_least_squares(first, w, target, n_ctrl, self.smooth_penalty)
        index = first[:, None] + np.arange(ORDER, dtype=np.int32)[None]
        feats = (jnp.asarray(index), jnp.asarray(w, jnp.float32))
        return jnp.asarray(weights, jnp.float32), feats, (t0, duration)

    @staticmethod
    def points(weights, feats):
        """weights (n + 3, 3J) m, features (index, weight) (T, 4) -> points (3, T, J) mm."""
        index, w = feats
        out = sum(w[:, k, None] * weights[index[:, k]] for k in range(ORDER))
        t = index.shape[0]
        return (MM_PER_M * out).reshape(t, 3, -1).transpose(1, 0, 2)

    def trajectory(self, params, span, num_joints: int):
        return SplineTrajectory(self, span[0], span[1], np.asarray(params, dtype=np.float64), num_joints)


def banded_least_squares(first: np.ndarray, w: np.ndarray, target: np.ndarray, n_ctrl: int, penalty: float):
    """argmin_W |B W - target|^2 + lam |D2 W|^2 with B the (T, n_ctrl) spline matrix given by ``first``
    (T,) and ``w`` (T, 4), D2 second differences, lam = ``penalty`` x mean diag(B^T B). Banded solve."""
    t = len(first)
    rows = np.repeat(np.arange(t), ORDER)
    cols = (first[:, None] + np.arange(ORDER)[None]).reshape(-1)
    basis = scipy.sparse.csr_matrix((w.reshape(-1), (rows, cols)), shape=(t, n_ctrl))
    gram = (basis.T @ basis).todia()
    lam = penalty * float(gram.diagonal().mean())
    d2 = scipy.sparse.diags([1.0, -2.0, 1.0], [0, 1, 2], shape=(max(n_ctrl - 2, 0), n_ctrl))
    system = (gram + lam * (d2.T @ d2)).tocsr()
    upper = np.zeros((ORDER, n_ctrl))
    for k in range(ORDER):
        upper[ORDER - 1 - k, k:] = system.diagonal(k)
    return scipy.linalg.solveh_banded(upper, basis.T @ target, check_finite=False)


@dataclass(frozen=True, eq=False)
class SplineTrajectory:
    """A fitted B-spline trajectory: call with times (K,) s -> (K, J, 3) mm."""

    basis: BSplineBasis
    t0: float
    duration: float
    weights_m: np.ndarray  # (n + 3, 3J)
    num_joints: int

    def __call__(self, times_s) -> np.ndarray:
        t = check_span(times_s, self.t0, self.duration)
        first, w = self.basis.locate(t, self.t0, self.duration)
        out = sum(w[:, k, None] * self.weights_m[first + k] for k in range(ORDER))
        return (MM_PER_M * out).reshape(len(t), 3, self.num_joints).transpose(0, 2, 1)
