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

Some joints may have a knot grid of their own, faster than the body's (``fast_max_freq_hz`` for
``fast_joints``). By default the knees, at 12 Hz: a knee extends quickly before heel strike, which the 8 Hz
grid lags (the simulator's knee flexion 3.19 -> 2.88 deg RMSE, the real walks' within 0.2 deg either way,
the gait events unchanged: docs/kinematics.md). The feet can have it instead (measured, not the default:
a foot lands in about 20 ms, and the 8 Hz grid rounds the heel's 7-13 mm dip at landing so that heel
strikes come 4-15 ms late even without detector noise, but with detector noise a faster heel lets in more
noise than it takes lag out: docs/gait.md). Each grid is a group of
joints with its own control points; the model's points are the groups' points put back in the skeleton's
joint order.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np
import scipy.linalg
import scipy.sparse
from gaitcap.reconstruction.fits.common import check_span

MM_PER_M = 1000.0
ORDER = 4  # cubic: 4 control points per frame
#: the knees: ``fast_joints`` for the knees' own grid
KNEE_JOINTS: tuple[str, ...] = ("left_knee", "right_knee")
#: the joints of the feet (those of them the skeleton has): ``fast_joints`` for the feet's own grid
FOOT_JOINTS: tuple[str, ...] = tuple(f"{side}_{part}" for side in ("left", "right")
                                     for part in ("ankle", "heel", "big_toe", "small_toe", "foot_index"))


def cubic_weights(s: np.ndarray) -> np.ndarray:
    """Uniform cubic B-spline weights (K, 4) at fractions ``s`` (K,) in [0, 1] of a knot interval."""
    s = np.asarray(s, dtype=np.float64)
    s2, s3 = s * s, s * s * s
    return np.stack(
        [(1 - s) ** 3 / 6, (3 * s3 - 6 * s2 + 4) / 6, (-3 * s3 + 3 * s2 + 3 * s + 1) / 6, s3 / 6], -1
    )


@dataclass(frozen=True)
class Grid:
    """One knot grid: its band limit (Hz) and the joints (indices into the skeleton) it carries."""

    max_freq_hz: float
    joints: tuple[int, ...]


@dataclass(frozen=True)
class SplineSpan:
    """Where a fitted spline lives: start ``t0`` s, ``duration`` s, and its knot grids."""

    t0: float
    duration: float
    grids: tuple[Grid, ...]


@dataclass(frozen=True)
class BSplineBasis:
    """Cubic B-spline time model.

    Attributes:
        max_freq_hz: band limit, Hz; sets the knot spacing with ``knots_per_cycle``.
        knots_per_cycle: knots per period of ``max_freq_hz`` (2: the Nyquist spacing).
        smooth_penalty: weight of the second-difference penalty of the least-squares start, relative
            to the mean diagonal of B^T B.
        fast_max_freq_hz: band limit, Hz, of the knot grid of ``fast_joints`` (12: the knees' default);
            None: every joint on the body's grid.
        fast_joints: the joints that ``fast_max_freq_hz`` applies to (:data:`FOOT_JOINTS`,
            :data:`KNEE_JOINTS` or both; names the skeleton lacks are ignored).
    """

    max_freq_hz: float = 8.0
    knots_per_cycle: float = 2.0
    smooth_penalty: float = 1e-3
    fast_max_freq_hz: float | None = 12.0
    fast_joints: tuple[str, ...] = KNEE_JOINTS

    def __post_init__(self) -> None:
        if not self.max_freq_hz > 0:
            raise ValueError(f"max_freq_hz: must be > 0 Hz, got {self.max_freq_hz}")
        if not self.knots_per_cycle > 0:
            raise ValueError(f"knots_per_cycle: must be > 0, got {self.knots_per_cycle}")
        if self.fast_max_freq_hz is not None and not self.fast_max_freq_hz > 0:
            raise ValueError(f"fast_max_freq_hz: must be > 0 Hz or None, got {self.fast_max_freq_hz}")

    def intervals(self, duration_s: float, max_freq_hz: float | None = None) -> int:
        """Number of knot intervals over a trial of ``duration_s`` s (at least 1) at ``max_freq_hz``
        (default: the body's band limit)."""
        hz = self.max_freq_hz if max_freq_hz is None else max_freq_hz
        return max(int(math.ceil(duration_s * self.knots_per_cycle * hz - 1e-9)), 1)

    def grids(self, num_joints: int, joint_names: Sequence[str] = ()) -> tuple[Grid, ...]:
        """The knot grids of a skeleton of ``num_joints`` joints named ``joint_names`` (without names:
        one grid): the body's, then the fast joints' where ``fast_max_freq_hz`` is set; empty grids left out."""
        fast = self.fast_max_freq_hz
        quick = tuple(j for j, name in enumerate(joint_names) if fast is not None and name in self.fast_joints)
        body = tuple(j for j in range(num_joints) if j not in quick)
        return tuple(Grid(hz, joints) for hz, joints in ((self.max_freq_hz, body), (fast, quick)) if joints)

    def model_bytes(self, frames: int, duration_s: float, joints: int) -> int:
        """Bytes of the model's own arrays in a fit: per-frame features and the float32 control points
        with the solver's copies of them (L-BFGS keeps 20), linear in the trial; the fast joints' grid,
        when set, counted as if it carried all of ``fast_joints``."""
        quick = min(len(self.fast_joints), joints) if self.fast_max_freq_hz is not None else 0
        grids = [(self.max_freq_hz, joints)] + ([(self.fast_max_freq_hz, quick)] if quick else [])
        return sum(32 * frames + 4 * 32 * (self.intervals(duration_s, hz) + ORDER - 1) * 3 * n for hz, n in grids)

    def locate(self, times_s: np.ndarray, t0: float, duration: float,
               max_freq_hz: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(K,) s -> first control point index (K,) int and weights (K, 4) of each time on the grid of
        ``max_freq_hz`` (default: the body's)."""
        n = self.intervals(duration, max_freq_hz)
        u = (np.asarray(times_s, dtype=np.float64) - t0) / duration * n
        first = np.clip(np.floor(u), 0, n - 1).astype(np.int32)
        return first, cubic_weights(np.clip(u - first, 0.0, 1.0))

    def init(self, times_s: np.ndarray, init_mm: np.ndarray, key, *, joint_names: Sequence[str] = ()):
        """Control points of each grid (a tuple of (n_g + 3, 3 J_g) m) fitted to ``init_mm`` (T, J, 3),
        the frames' features ((index, weights) per grid, and the joint order), and the span
        (:class:`SplineSpan`). ``joint_names`` (J,) places ``fast_joints`` on their own grid."""
        t0, duration = float(times_s[0]), max(float(times_s[-1] - times_s[0]), 1e-3)
        t, j, _ = init_mm.shape
        grids = self.grids(j, joint_names)
        params, feats = [], []
        for grid in grids:
            first, w = self.locate(times_s, t0, duration, grid.max_freq_hz)
            n_ctrl = self.intervals(duration, grid.max_freq_hz) + ORDER - 1
            joints = list(grid.joints)
            # (T, 3 J_g), column k * J_g + j
            target = np.transpose(init_mm[:, joints], (0, 2, 1)).reshape(t, 3 * len(joints)) / MM_PER_M
            weights = banded_least_squares(first, w, target, n_ctrl, self.smooth_penalty)
            index = first[:, None] + np.arange(ORDER, dtype=np.int32)[None]
            params.append(jnp.asarray(weights, jnp.float32))
            feats.append((jnp.asarray(index), jnp.asarray(w, jnp.float32)))
        order = np.argsort(np.concatenate([g.joints for g in grids])).astype(np.int32)
        return tuple(params), (tuple(feats), jnp.asarray(order)), SplineSpan(t0, duration, grids)

    @staticmethod
    def points(params, feats):
        """params: control points per grid ((n_g + 3, 3 J_g) m); features: ((index, weight) (T, 4) per
        grid, joint order (J,)) -> points (3, T, J) mm."""
        grids, order = feats
        parts = [_grid_points(weights, index, w) for weights, (index, w) in zip(params, grids, strict=True)]
        return jnp.concatenate(parts, -1)[..., order]

    def trajectory(self, params, span: SplineSpan, num_joints: int):
        return SplineTrajectory(self, span.t0, span.duration, span.grids,
                                tuple(np.asarray(p, dtype=np.float64) for p in params), num_joints)


def _grid_points(weights, index, w):
    """One grid's control points (n + 3, 3 J_g) m at features (T, 4) -> points (3, T, J_g) mm."""
    out = sum(w[:, k, None] * weights[index[:, k]] for k in range(ORDER))
    return (MM_PER_M * out).reshape(index.shape[0], 3, -1).transpose(1, 0, 2)


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
    grids: tuple[Grid, ...]
    weights_m: tuple[np.ndarray, ...]  # per grid (n_g + 3, 3 J_g)
    num_joints: int

    def __call__(self, times_s) -> np.ndarray:
        t = check_span(times_s, self.t0, self.duration)
        out = np.zeros((len(t), self.num_joints, 3))
        for grid, weights in zip(self.grids, self.weights_m, strict=True):
            first, w = self.basis.locate(t, self.t0, self.duration, grid.max_freq_hz)
            part = sum(w[:, k, None] * weights[first + k] for k in range(ORDER))
            out[:, list(grid.joints)] = (MM_PER_M * part).reshape(len(t), 3, len(grid.joints)).transpose(0, 2, 1)
        return out
