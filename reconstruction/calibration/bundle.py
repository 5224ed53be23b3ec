"""Bundle adjustment of all cameras (intrinsics + extrinsics) and all board poses.

Levenberg-Marquardt on the sparse normal equations (analytic Jacobian, scipy sparse LU), a robust
loss by iteratively reweighted least squares, and rounds of outlier rejection: after each solve, corners whose reprojection error exceeds
``outlier_sigmas`` robust standard deviations are dropped and the problem is solved again. The root
camera's extrinsics are held fixed (it defines the frame until the world frame is set); the board's
square size fixes the scale.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import Literal

import numpy as np
from gaitcap.reconstruction.calibration.geometry import rodrigues_batch, rvec_of
from gaitcap.reconstruction.distortion import distort, radial_factor
from scipy.sparse import csr_matrix, diags
from scipy.sparse.linalg import spsolve

log = logging.getLogger(__name__)

RAYLEIGH_MEDIAN = float(np.sqrt(2 * np.log(2)))  # median of |e| / sigma for 2D Gaussian noise


@dataclass(frozen=True)
class BundleConfig:
    """Bundle-adjustment settings.

    Attributes:
        loss: scipy robust loss.
        f_scale_px: residual scale of the robust loss, px.
        outlier_sigmas: corners beyond this many robust sigmas are rejected after each round.
        min_outlier_px: never reject corners closer than this, px.
        max_rounds: solve / reject rounds.
        max_iterations: Levenberg-Marquardt iterations per solve.
        tolerance: stop when the robust cost falls by less than this fraction.
        refine_intrinsics: also adjust K and the free distortion terms.
        refine_cameras: also adjust the camera poses (False: only the board poses are fitted, the rig
            held as given: how well a given calibration explains the corners).
    """

    loss: Literal["soft_l1", "huber", "cauchy", "linear"] = "soft_l1"
    f_scale_px: float = 1.0
    outlier_sigmas: float = 5.0
    min_outlier_px: float = 1.5
    max_rounds: int = 4
    max_iterations: int = 100
    tolerance: float = 1e-10
    refine_intrinsics: bool = True
    refine_cameras: bool = True


@dataclass(frozen=True, eq=False)
class BundleProblem:
    """Observed corners, flattened: one row per (camera, frame, corner).

    Attributes:
        cam: (P,) camera index; frame: (P,) frame index; corner: (P,) corner id (true order);
        uv_px: (P, 2) observed px; object_points_mm: (N, 3) board corners; root: fixed camera;
        free_dist: indices into (k1, k2, p1, p2, k3) that are adjusted;
        held_principal_point: (C,) cameras whose principal point stays where it starts (None: none);
        held_distortion: (C, 5) bool, distortion terms (k1, k2, p1, p2, k3) of a camera that stay where
            they start although ``free_dist`` frees them (None: none).
        focal_group: (C,) int, cameras of one group (>= 0; -1: none) are identical models: a prior pulls
            each one's focal lengths (fx, fy) towards the group's mean, with a standard deviation of
            ``focal_prior_rel`` times the group's starting mean (None: no prior).
        weight: (P,) each corner's relative weight, the inverse of its error variance relative to the
            slowest views' (a corner of a view where the board moved fast is less precise:
            :mod:`gaitcap.reconstruction.calibration.motion`); the robust loss and the outlier rounds
            judge the weighted (standardised) error (None: every corner weighs 1).
        velocity_px_s: (P, 2) each corner's image velocity (px/s, 0 where unknown): given, each camera
            but the root gets a time offset d (s), its corners seen where the board was d after the
            frame set's instant (projected + v d), adjusted with the rest (None: no offsets).
    """

    cam: np.ndarray
    frame: np.ndarray
    corner: np.ndarray
    uv_px: np.ndarray
    object_points_mm: np.ndarray
    num_cameras: int
    num_frames: int
    root: int
    free_dist: tuple[int, ...]
    held_principal_point: np.ndarray | None = None
    held_distortion: np.ndarray | None = None
    focal_group: np.ndarray | None = None
    focal_prior_rel: float = 0.01
    weight: np.ndarray | None = None
    velocity_px_s: np.ndarray | None = None

    def weights(self, rows: np.ndarray) -> np.ndarray:
        """(len(rows),) the corners' relative weights (1 where none are given)."""
        return np.ones(len(rows)) if self.weight is None else self.weight[rows]


@dataclass(frozen=True, eq=False)
class BundleState:
    """Parameters: K (C, 3, 3), dist (C, 5), cam R (C, 3, 3) world->camera, cam t (C, 3) mm,
    board R (F, 3, 3) board->world, board t (F, 3) mm; time_offset_s (C,): each camera's exposure after
    the frame set's instant (s; used only where the problem gives velocities)."""

    matrix_px: np.ndarray
    dist: np.ndarray
    cam_rotation: np.ndarray
    cam_tvec_mm: np.ndarray
    frame_rotation: np.ndarray
    frame_tvec_mm: np.ndarray
    time_offset_s: np.ndarray | None = None

    def offsets(self, n_cams: int) -> np.ndarray:
        """(C,) the time offsets, s (0 where none)."""
        return np.zeros(n_cams) if self.time_offset_s is None else self.time_offset_s


@dataclass(frozen=True, eq=False)
class BundleResult:
    """The adjusted state, each observed corner's residual (P, 2) px and inlier flag (P,)."""

    state: BundleState
    residual_px: np.ndarray
    inlier: np.ndarray
    rounds: int
    solve_time_s: float


class _Layout:
    """Maps parameters to/from the flat vector: [intrinsics C*(4+D) | extrinsics (C-1)*6 | frames F*6 |
    time offsets C-1 where the problem gives velocities and the cameras are adjusted]."""

    def __init__(self, prob: BundleProblem, refine_intrinsics: bool, refine_cameras: bool = True):
        self.prob, self.refine = prob, refine_intrinsics
        self.n_intr = (4 + len(prob.free_dist)) if refine_intrinsics else 0
        self.cams_free = [c for c in range(prob.num_cameras) if c != prob.root] if refine_cameras else []
        self.o_ext = prob.num_cameras * self.n_intr
        self.o_frame = self.o_ext + 6 * len(self.cams_free)
        self.o_off = self.o_frame + 6 * prob.num_frames
        self.timed = prob.velocity_px_s is not None and refine_cameras
        self.size = self.o_off + (len(self.cams_free) if self.timed else 0)

    def prior(self, s: BundleState) -> csr_matrix:
        """The shared focal prior as a quadratic form M (size, size): its cost is x' M x (the sum of the
        squared standardised deviations of each grouped camera's fx, fy from its group's mean)."""
        p = self.prob
        m = csr_matrix((self.size, self.size))
        if not self.refine or p.focal_group is None:
            return m
        rows, cols, vals = [], [], []
        for g in np.unique(p.focal_group[p.focal_group >= 0]):
            cams = np.flatnonzero(p.focal_group == g)
            if len(cams) < 2:
                continue
            for axis in (0, 1):
                sigma = p.focal_prior_rel * float(np.mean(s.matrix_px[cams, axis, axis]))
                idx = self.n_intr * cams + axis
                proj = (np.eye(len(cams)) - 1.0 / len(cams)) / sigma**2
                rows.append(np.repeat(idx, len(cams)))
                cols.append(np.tile(idx, len(cams)))
                vals.append(proj.ravel())
        if rows:
            m = csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                           shape=(self.size, self.size))
        return m

    def pack(self, s: BundleState) -> np.ndarray:
        x = np.zeros(self.size)
        if self.refine:
            k = s.matrix_px
            intr = np.column_stack([k[:, 0, 0], k[:, 1, 1], k[:, 0, 2], k[:, 1, 2], s.dist[:, list(self.prob.free_dist)]])
            x[: self.o_ext] = intr.ravel()
        ext = [np.r_[rvec_of(s.cam_rotation[c]), s.cam_tvec_mm[c]] for c in self.cams_free]
        x[self.o_ext : self.o_frame] = np.ravel(ext)
        frames = [np.r_[rvec_of(s.frame_rotation[f]), s.frame_tvec_mm[f]] for f in range(self.prob.num_frames)]
        x[self.o_frame : self.o_off] = np.ravel(frames)
        if self.timed:
            x[self.o_off :] = s.offsets(self.prob.num_cameras)[self.cams_free]
        return x

    def unpack(self, x: np.ndarray, base: BundleState) -> BundleState:
        k, dist = base.matrix_px.copy(), base.dist.copy()
        if self.refine:
            intr = x[: self.o_ext].reshape(self.prob.num_cameras, self.n_intr)
            k[:, 0, 0], k[:, 1, 1], k[:, 0, 2], k[:, 1, 2] = intr[:, 0], intr[:, 1], intr[:, 2], intr[:, 3]
            dist[:, list(self.prob.free_dist)] = intr[:, 4:]
        cam_r, cam_t = base.cam_rotation.copy(), base.cam_tvec_mm.copy()
        ext = x[self.o_ext : self.o_frame].reshape(-1, 6)
        if len(self.cams_free):
            cam_r[self.cams_free] = rodrigues_batch(ext[:, :3])
            cam_t[self.cams_free] = ext[:, 3:]
        fr = x[self.o_frame : self.o_off].reshape(-1, 6)
        offsets = base.time_offset_s
        if self.timed:
            offsets = base.offsets(self.prob.num_cameras).copy()
            offsets[self.cams_free] = x[self.o_off :]
        return BundleState(k, dist, cam_r, cam_t, rodrigues_batch(fr[:, :3]), fr[:, 3:].copy(), offsets)

    def rvecs(self, x: np.ndarray, base: BundleState) -> tuple[np.ndarray, np.ndarray]:
        """Rotation vectors of the frames (F, 3) and cameras (C, 3) at parameters x."""
        cam_rv = np.stack([rvec_of(r) for r in base.cam_rotation])
        if self.cams_free:
            cam_rv[self.cams_free] = x[self.o_ext : self.o_frame].reshape(-1, 6)[:, :3]
        return x[self.o_frame : self.o_off].reshape(-1, 6)[:, :3], cam_rv

    def columns(self, rows: np.ndarray) -> np.ndarray:
        """(len(rows), 12 + n_intr) parameter columns of each corner: frame, camera pose, intrinsics.
        The root camera's pose columns point at its frame's first column (their values are 0)."""
        p = self.prob
        cam, frame = p.cam[rows], p.frame[rows]
        cols = [self.o_frame + 6 * frame[:, None] + np.arange(6)]
        slot = np.full(p.num_cameras, -1)
        slot[self.cams_free] = np.arange(len(self.cams_free))
        ext = self.o_ext + 6 * slot[cam][:, None] + np.arange(6)
        cols.append(np.where(slot[cam][:, None] >= 0, ext, cols[0][:, :1]))
        if self.refine:
            cols.append(self.n_intr * cam[:, None] + np.arange(self.n_intr))
        if self.timed:  # the root's offset column points at its frame's first column (its value is 0)
            cols.append(np.where(slot[cam] >= 0, self.o_off + slot[cam], cols[0][:, 0])[:, None])
        return np.concatenate(cols, axis=1)

    def jacobian(self, proj: _Projection, rows: np.ndarray, cols: np.ndarray) -> csr_matrix:
        """Sparse Jacobian (2 len(rows), size) from the projection's derivative blocks."""
        held = ~np.isin(self.prob.cam[rows], self.cams_free)[:, None, None]  # the root, or every camera
        blocks = [proj.d_frame, np.where(held, 0.0, proj.d_cam)]
        if self.refine:
            d_intr = proj.d_intr[:, :, list(range(4)) + [4 + i for i in self.prob.free_dist]]
            if self.prob.held_principal_point is not None:  # a zero column: LM never moves it
                held = self.prob.held_principal_point[self.prob.cam[rows]]
                d_intr[held, :, 2:4] = 0.0
            if self.prob.held_distortion is not None:
                held = self.prob.held_distortion[self.prob.cam[rows]][:, list(self.prob.free_dist)]  # (P, D)
                d_intr[:, :, 4:] = np.where(held[:, None, :], 0.0, d_intr[:, :, 4:])
            blocks.append(d_intr)
        if self.timed:
            fixed = ~np.isin(self.prob.cam[rows], self.cams_free)[:, None, None]
            blocks.append(np.where(fixed, 0.0, self.prob.velocity_px_s[rows][:, :, None]))
        vals = np.concatenate(blocks, axis=-1)  # (P, 2, K)
        r = np.arange(len(rows))
        row_idx = np.stack([2 * r, 2 * r + 1], 1)[:, :, None].repeat(cols.shape[1], 2)
        col_idx = np.broadcast_to(cols[:, None, :], vals.shape)
        return csr_matrix((vals.ravel(), (row_idx.ravel(), col_idx.ravel())), shape=(2 * len(rows), self.size))


def _skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices (P, 3, 3) of vectors (P, 3)."""
    z = np.zeros(len(v))
    return np.stack([np.stack([z, -v[:, 2], v[:, 1]], -1), np.stack([v[:, 2], z, -v[:, 0]], -1),
                     np.stack([-v[:, 1], v[:, 0], z], -1)], -2)


def _right_jacobian(rvecs: np.ndarray) -> np.ndarray:
    """SO(3) right Jacobians (K, 3, 3) of rotation vectors (K, 3): R(r + d) ~ R(r) exp(J_r d)."""
    theta = np.linalg.norm(rvecs, axis=-1)[:, None, None]
    k = _skew(rvecs)
    small = theta < 1e-6
    t = np.where(small, 1.0, theta)
    a = np.where(small, 0.5, (1 - np.cos(t)) / t**2)
    b = np.where(small, 1.0 / 6.0, (t - np.sin(t)) / t**3)
    return np.eye(3) - a * k + b * (k @ k)


@dataclass(frozen=True, eq=False)
class _Projection:
    """Predicted px (P, 2) and, when asked, the derivative blocks of every corner's projection."""

    uv: np.ndarray
    d_frame: np.ndarray | None = None  # (P, 2, 6): board rvec, tvec
    d_cam: np.ndarray | None = None  # (P, 2, 6): camera rvec, tvec
    d_intr: np.ndarray | None = None  # (P, 2, 9): fx, fy, cx, cy, k1, k2, p1, p2, k3


def _project(state: BundleState, prob: BundleProblem, rows: np.ndarray, *, derivatives: bool = False,
             rvecs: tuple[np.ndarray, np.ndarray] | None = None) -> _Projection:
    cam, frame = prob.cam[rows], prob.frame[rows]
    obj = prob.object_points_mm[prob.corner[rows]]
    r_f, r_c = state.frame_rotation[frame], state.cam_rotation[cam]
    rotated = np.einsum("pij,pj->pi", r_f, obj)
    world = rotated + state.frame_tvec_mm[frame]
    pc = np.einsum("pij,pj->pi", r_c, world) + state.cam_tvec_mm[cam]
    iz = 1.0 / pc[:, 2]
    x, y = pc[:, 0] * iz, pc[:, 1] * iz
    k1, k2, p1, p2, k3 = state.dist[cam].T
    r2 = x * x + y * y
    radial = radial_factor(r2, k1, k2, k3)
    xd, yd = distort(x, y, k1, k2, p1, p2, k3)
    k = state.matrix_px[cam]
    fx, fy = k[:, 0, 0], k[:, 1, 1]
    uv = np.stack([fx * xd + k[:, 0, 2], fy * yd + k[:, 1, 2]], axis=-1)
    if prob.velocity_px_s is not None and state.time_offset_s is not None:
        uv = uv + prob.velocity_px_s[rows] * state.time_offset_s[cam][:, None]
    if not derivatives:
        return _Projection(uv)
    dr = k1 + 2 * k2 * r2 + 3 * k3 * r2**2
    dist_xy = np.stack([
        np.stack([radial + 2 * x * x * dr + 2 * p1 * y + 6 * p2 * x, 2 * x * y * dr + 2 * p1 * x + 2 * p2 * y], -1),
        np.stack([2 * x * y * dr + 2 * p1 * x + 2 * p2 * y, radial + 2 * y * y * dr + 6 * p1 * y + 2 * p2 * x], -1),
    ], -2)  # (P, 2, 2)
    zero = np.zeros_like(x)
    proj = np.stack([np.stack([iz, zero, -x * iz], -1), np.stack([zero, iz, -y * iz], -1)], -2)  # (P, 2, 3)
    d_pc = np.stack([fx, fy], -1)[:, :, None] * (dist_xy @ proj)  # d uv / d camera point (P, 2, 3)
    frame_rv, cam_rv = rvecs
    d_world = d_pc @ r_c
    d_rf = -d_world @ r_f @ _skew(obj) @ _right_jacobian(frame_rv)[frame]
    d_rc = -d_pc @ r_c @ _skew(world) @ _right_jacobian(cam_rv)[cam]
    d_dist = np.stack([
        np.stack([x * r2, x * r2**2, 2 * x * y, r2 + 2 * x * x, x * r2**3], -1),
        np.stack([y * r2, y * r2**2, r2 + 2 * y * y, 2 * x * y, y * r2**3], -1),
    ], -2) * np.stack([fx, fy], -1)[:, :, None]
    one = np.ones_like(x)
    d_k = np.stack([np.stack([xd, zero, one, zero], -1), np.stack([zero, yd, zero, one], -1)], -2)
    return _Projection(uv, np.concatenate([d_rf, d_world], -1), np.concatenate([d_rc, d_pc], -1),
                       np.concatenate([d_k, d_dist], -1))


def project_corners(state: BundleState, prob: BundleProblem, rows: np.ndarray) -> np.ndarray:
    """Predicted px (len(rows), 2) of observed corners ``rows``."""
    return _project(state, prob, rows).uv


def _soft_l1(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return 2 * (np.sqrt(1 + z) - 1), 1 / np.sqrt(1 + z)


def _huber(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    root = np.sqrt(np.maximum(z, 1e-300))
    return np.where(z <= 1, z, 2 * root - 1), np.where(z <= 1, 1.0, 1 / root)


def _cauchy(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.log1p(z), 1 / (1 + z)


def _linear(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return z, np.ones_like(z)


# rho(z) and rho'(z) of z = (|e| / f_scale)^2 for each corner's 2D error e
LOSSES = {"soft_l1": _soft_l1, "huber": _huber, "cauchy": _cauchy, "linear": _linear}


def _robust(layout: _Layout, state: BundleState, x: np.ndarray, rows: np.ndarray, config: BundleConfig):
    """Robust cost and the per-corner IRLS weights (P,) at parameters x."""
    err = _project(layout.unpack(x, state), layout.prob, rows).uv - layout.prob.uv_px[rows]
    w = layout.prob.weights(rows)
    rho, weight = LOSSES[config.loss](w * np.sum(err**2, -1) / config.f_scale_px**2)
    return float(config.f_scale_px**2 * rho.sum()), err, weight * w


def _solve(layout: _Layout, state: BundleState, rows: np.ndarray, config: BundleConfig) -> BundleState:
    """Levenberg-Marquardt with IRLS weights for the robust loss; sparse normal equations."""
    cols = layout.columns(rows)
    x = layout.pack(state)
    prior = layout.prior(state)
    cost, err, weight = _robust(layout, state, x, rows, config)
    cost += float(x @ (prior @ x))
    lam = 1e-3
    for it in range(config.max_iterations):  # noqa: B007
        proj = _project(layout.unpack(x, state), layout.prob, rows, derivatives=True, rvecs=layout.rvecs(x, state))
        jac = layout.jacobian(proj, rows, cols)
        w = np.repeat(weight, 2)
        jtw = jac.T.multiply(w).tocsr()
        hess = (jtw @ jac + prior).tocsc()
        grad = jtw @ err.ravel() + prior @ x
        diag = np.maximum(hess.diagonal(), 1e-12)
        while True:
            step = spsolve(hess + diags(lam * diag), -grad)
            new_cost, new_err, new_weight = _robust(layout, state, x + step, rows, config)
            new_cost += float((x + step) @ (prior @ (x + step)))
            if np.isfinite(new_cost) and new_cost < cost:
                break
            lam *= 4.0
            if lam > 1e12:
                return layout.unpack(x, state)
        x, lam = x + step, max(lam / 3.0, 1e-9)
        converged = cost - new_cost < config.tolerance * cost
        cost, err, weight = new_cost, new_err, new_weight
        if converged:
            break
    log.debug("bundle: %d corners, cost %.6g after %d iterations", len(rows), cost, it + 1)
    return layout.unpack(x, state)


def outlier_threshold_px(err_px: np.ndarray, config: BundleConfig) -> float:
    """Corners farther than this (px) are outliers, given the inliers' errors (P,) px."""
    sigma = np.median(err_px) / RAYLEIGH_MEDIAN
    return float(max(config.outlier_sigmas * sigma, config.min_outlier_px))


def bundle_adjust(prob: BundleProblem, initial: BundleState, config: BundleConfig,
                  exclude: np.ndarray | None = None) -> BundleResult:
    """Robust bundle adjustment with rounds of outlier rejection; ``exclude`` (P,) bool: corners left
    out from the start (never inliers; their residuals are still given)."""
    t0 = time.perf_counter()
    layout = _Layout(prob, config.refine_intrinsics, config.refine_cameras)
    allowed = np.ones(len(prob.cam), dtype=bool) if exclude is None else ~np.asarray(exclude, dtype=bool)
    inlier = allowed.copy()
    state, rounds = initial, 0
    for rounds in range(1, config.max_rounds + 1):  # noqa: B007
        state = _solve(layout, state, np.flatnonzero(inlier), config)
        err = np.linalg.norm(project_corners(state, prob, np.arange(len(prob.cam))) - prob.uv_px, axis=-1)
        err = err * np.sqrt(prob.weights(np.arange(len(prob.cam))))  # standardised where weighted
        keep = (err <= outlier_threshold_px(err[inlier], config)) & allowed
        log.info("bundle round %d: median error %.3f px, %d outliers", rounds, np.median(err[inlier]), (~keep).sum())
        if np.array_equal(keep, inlier):
            break
        inlier = keep
    residual = project_corners(state, prob, np.arange(len(prob.cam))) - prob.uv_px
    return BundleResult(state, residual, inlier, rounds, time.perf_counter() - t0)
