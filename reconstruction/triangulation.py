"""Confidence-weighted DLT and the paper's robust triangulation, in closed form on arrays.

Everything works on undistorted normalised image coordinates laid out as (N, C) (N = T * J points,
cameras LAST so the sums over cameras and pairs are fast last-axis reductions on XLA:CPU). One DLT is
the 3x3 normal-equation system of the weighted rows ``w (x p3 - p1)``, ``w (y p3 - p2)`` with the
dehomogenised point X = (x, y, z, 1), solved by explicit cofactors, so there is no vmapped SVD.
World coordinates inside are metres (conditioning in float32); results are mm.

Robust triangulation (Cotton et al. 2023 and the authors' code): views with confidence below gamma are
dropped, every camera pair is triangulated, the geometric median of the pair points is found by
Weiszfeld iteration (start at the mean, at most 100 iterations, stop at 0.01 mm), each pair point gets
weight exp(-d^2 / sigma^2) from its distance d to the median, a camera's weight is the median over its
pairs (0 if none), and a final DLT uses those weights.

A point with fewer than two usable views (or a degenerate geometry) is NaN, never a wild value.
"""

from __future__ import annotations

import logging
from functools import partial
from itertools import combinations

import jax
import jax.numpy as jnp
import numpy as np
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.projection import CameraArrays, camera_arrays, undistort_pixels
from gaitcap.reconstruction.result import Reconstruction

log = logging.getLogger(__name__)

MM_PER_M = 1000.0
MIN_VIEW_WEIGHT = 1e-3  # a view counts as usable in the final DLT above this weight
DET_REL_TOL = 1e-7  # det(M) / trace(M)^3 below this: degenerate (near-parallel rays)


# ----------------------------------------------------------------------------- closed-form DLT


def _dlt_terms(xn, yn, cams: CameraArrays):
    """Per-view contributions to the normal equations, each (N, C).

    Rows of view c: (x R3 - R1) . X + (x t3 - t1) and the same with y, R2, t2 (metres).
    Returns the 6 unique entries of sum r r^T and the 3 entries of sum r * b.
    """
    c = cams.num_cameras
    rot = cams.rot_rows  # (3C, 3)
    t_m = cams.t_mm[:, 0] / MM_PER_M
    r1, r2, r3 = rot[:c], rot[c : 2 * c], rot[2 * c :]  # (C, 3)
    t1, t2, t3 = t_m[:c], t_m[c : 2 * c], t_m[2 * c :]  # (C,)
    ax = [xn * r3[:, i] - r1[:, i] for i in range(3)]  # each (N, C)
    ay = [yn * r3[:, i] - r2[:, i] for i in range(3)]
    bx = xn * t3 - t1
    by = yn * t3 - t2
    m = {}
    for i in range(3):
        for j in range(i, 3):
            m[i, j] = ax[i] * ax[j] + ay[i] * ay[j]
    rhs = [ax[i] * bx + ay[i] * by for i in range(3)]
    return m, rhs


def _solve_sym3(m, rhs):
    """Solve M x = -rhs for symmetric 3x3 M given by entries m[i, j] (i <= j), arrays of any shape.

    Returns (x (3 arrays), ok mask) where ok is False for degenerate systems.
    """
    a, b, c = m[0, 0], m[0, 1], m[0, 2]
    d, e, f = m[1, 1], m[1, 2], m[2, 2]
    c00 = d * f - e * e
    c01 = c * e - b * f
    c02 = b * e - c * d
    c11 = a * f - c * c
    c12 = b * c - a * e
    c22 = a * d - b * b
    det = a * c00 + b * c01 + c * c02
    trace = a + d + f
    ok = jnp.abs(det) > DET_REL_TOL * trace**3
    inv_det = jnp.where(ok, 1.0 / jnp.where(ok, det, 1.0), jnp.nan)
    g0, g1, g2 = -rhs[0], -rhs[1], -rhs[2]
    x = (c00 * g0 + c01 * g1 + c02 * g2) * inv_det
    y = (c01 * g0 + c11 * g1 + c12 * g2) * inv_det
    z = (c02 * g0 + c12 * g1 + c22 * g2) * inv_det
    return (x, y, z), ok


def _weighted_dlt(m, rhs, w2):
    """DLT from per-view terms (N, C) with squared row weights w2 (N, C). Returns (N, 3) m and ok."""
    ms = {k: jnp.sum(v * w2, axis=-1) for k, v in m.items()}
    rs = [jnp.sum(r * w2, axis=-1) for r in rhs]
    (x, y, z), ok = _solve_sym3(ms, rs)
    return jnp.stack([x, y, z], -1), ok


def _prepare(keypoints, cams: CameraArrays):
    """keypoints (C, N, 3) px/conf -> undistorted xn, yn (N, C) and confidence (N, C), NaN -> 0."""
    kp = jnp.asarray(keypoints)
    u, v, conf = kp[..., 0], kp[..., 1], kp[..., 2]
    finite = jnp.isfinite(u) & jnp.isfinite(v) & jnp.isfinite(conf)
    u = jnp.where(finite, u, 0.0)
    v = jnp.where(finite, v, 0.0)
    conf = jnp.where(finite, conf, 0.0)
    xn, yn = undistort_pixels(u, v, cams)
    return xn.T, yn.T, conf.T


@jax.jit
def dlt_arrays(keypoints: jnp.ndarray, cams: CameraArrays, weights: jnp.ndarray):
    """Weighted DLT. keypoints (C, N, 3) px/conf, weights (C, N) (0 = unused view).

    Returns points (N, 3) mm (NaN where < 2 views with weight > MIN_VIEW_WEIGHT or degenerate).
    """
    xn, yn, _ = _prepare(keypoints, cams)
    w = jnp.where(jnp.isfinite(weights), weights, 0.0).T
    finite = jnp.isfinite(keypoints[..., :2]).all(-1).T
    w = jnp.where(finite, w, 0.0)
    m, rhs = _dlt_terms(xn, yn, cams)
    pts, ok = _weighted_dlt(m, rhs, w * w)
    ok = ok & (jnp.sum(w > MIN_VIEW_WEIGHT, axis=-1) >= 2)
    return jnp.where(ok[:, None], pts * MM_PER_M, jnp.nan)


# ----------------------------------------------------------------------------- robust


def camera_pairs(num_cameras: int) -> tuple[np.ndarray, np.ndarray]:
    """All unordered camera pairs as index arrays (P,), (P,)."""
    pairs = np.array(list(combinations(range(num_cameras), 2)), dtype=np.int32).reshape(-1, 2)
    return pairs[:, 0], pairs[:, 1]


def pair_matrix(num_cameras: int) -> np.ndarray:
    """(C, P) 0/1 matrix: column p has ones at the two cameras of pair p."""
    pi, pj = camera_pairs(num_cameras)
    sel = np.zeros((num_cameras, len(pi)), dtype=np.float32)
    sel[pi, np.arange(len(pi))] = 1.0
    sel[pj, np.arange(len(pi))] = 1.0
    return sel


def _pair_points(m, rhs, valid, sel):
    """Two-view DLT for every pair: points (3 arrays (N, P), metres) and validity (N, P).

    Pair sums are matmuls with the (C, P) selection matrix: fast, and a fusion barrier that keeps XLA
    from recomputing the undistortion once per pair.
    """
    mp = {k: v @ sel for k, v in m.items()}
    rp = [r @ sel for r in rhs]
    (x, y, z), ok = _solve_sym3(mp, rp)
    ok = ok & (valid.astype(sel.dtype) @ sel > 1.5)
    return (x, y, z), ok


def _geometric_median(px, py, pz, ok, max_iters: int, tol_m: float):
    """Weiszfeld geometric median over the last axis of (N, P) pair points where ``ok``."""
    okf = ok.astype(px.dtype)
    n = jnp.maximum(okf.sum(-1), 1.0)
    px, py, pz = (jnp.where(ok, p, 0.0) for p in (px, py, pz))
    start = tuple(p.sum(-1) / n for p in (px, py, pz))

    def step(state):
        (mx, my, mz), _, it = state
        d = jnp.sqrt((px - mx[:, None]) ** 2 + (py - my[:, None]) ** 2 + (pz - mz[:, None]) ** 2)
        inv = okf / jnp.maximum(d, 1e-9)
        s = jnp.maximum(inv.sum(-1), 1e-30)
        new = ((inv * px).sum(-1) / s, (inv * py).sum(-1) / s, (inv * pz).sum(-1) / s)
        moved = jnp.sqrt((new[0] - mx) ** 2 + (new[1] - my) ** 2 + (new[2] - mz) ** 2)
        return new, jnp.max(moved), it + 1

    def cond(state):
        _, moved, it = state
        return (it < max_iters) & (moved > tol_m)

    med, _, _ = jax.lax.while_loop(cond, step, (start, jnp.asarray(jnp.inf, px.dtype), 0))
    return med


def _masked_median(values, mask):
    """Median over the last axis of values where mask (NaN where the mask is empty).

    The last axis is short (C - 1 pairs per camera): an unrolled odd-even transposition sorting network
    with masked entries pushed to the end, then the middle one(s) of the valid count picked with
    selects. XLA:CPU's sort is about 20x slower for this shape.
    """
    cols = [jnp.where(mask[..., i], values[..., i], jnp.inf) for i in range(values.shape[-1])]
    n = len(cols)
    for rnd in range(n):
        for i in range(rnd % 2, n - 1, 2):
            cols[i], cols[i + 1] = jnp.minimum(cols[i], cols[i + 1]), jnp.maximum(cols[i], cols[i + 1])
    k = mask.sum(-1)
    lo = sum(jnp.where((k - 1) // 2 == i, col, 0.0) for i, col in enumerate(cols))
    hi = sum(jnp.where(k // 2 == i, col, 0.0) for i, col in enumerate(cols))
    return jnp.where(k > 0, 0.5 * (lo + hi), jnp.nan)


BLOCK_POINTS = 4096  # points per block: a block's arrays stay in cache and it stops iterating on its own


@partial(jax.jit, static_argnames=("max_iters", "block"))
def robust_arrays(
    keypoints: jnp.ndarray,
    cams: CameraArrays,
    *,
    gamma: float = 0.5,
    sigma_mm: float = 150.0,
    max_iters: int = 100,
    tol_mm: float = 0.01,
    block: int = BLOCK_POINTS,
):
    """Robust triangulation on arrays, in blocks of ``block`` points (a sequential map over blocks).

    Args:
        keypoints: (C, N, 3) x px, y px, confidence (NaN = missing view).
        cams: the rig as :class:`CameraArrays` (C cameras, same order).
        gamma: confidence threshold; views at or below it are dropped.
        sigma_mm: scale of the pair weights exp(-d^2 / sigma^2), mm.

    Returns:
        points (N, 3) mm (NaN if not triangulable), camera weights (C, N) in [0, 1].
    """
    c, n, _ = keypoints.shape
    b = min(block, n)
    nb = -(-n // b)
    kp = jnp.pad(keypoints, ((0, 0), (0, nb * b - n), (0, 0)), constant_values=jnp.nan)
    blocks = kp.reshape(c, nb, b, 3).transpose(1, 0, 2, 3)  # (nb, C, b, 3)

    def one(kp_block):
        return _robust_block(kp_block, cams, gamma, sigma_mm, max_iters, tol_mm)

    pts, cam_w = jax.lax.map(one, blocks)  # (nb, b, 3), (nb, b, C)
    return pts.reshape(nb * b, 3)[:n], cam_w.reshape(nb * b, c)[:n].T


def _robust_block(keypoints, cams: CameraArrays, gamma, sigma_mm, max_iters: int, tol_mm):
    """Robust triangulation of keypoints (C, B, 3): points (B, 3) mm and camera weights (B, C)."""
    c = cams.num_cameras
    xn, yn, conf = _prepare(keypoints, cams)
    valid = conf > gamma
    m, rhs = _dlt_terms(xn, yn, cams)
    (px, py, pz), ok = _pair_points(m, rhs, valid, jnp.asarray(pair_matrix(c), xn.dtype))
    mx, my, mz = _geometric_median(px, py, pz, ok, max_iters, tol_mm / MM_PER_M)
    d_mm = MM_PER_M * jnp.sqrt((px - mx[:, None]) ** 2 + (py - my[:, None]) ** 2 + (pz - mz[:, None]) ** 2)
    pair_w = jnp.exp(-((d_mm / sigma_mm) ** 2))
    table = _pair_table(c)  # camera c's pairs: gather (B, C, C-1)
    cam_w = _masked_median(pair_w[:, table], ok[:, table])  # (B, C)
    cam_w = jnp.where(jnp.isfinite(cam_w), cam_w, 0.0)
    pts, good = _weighted_dlt(m, rhs, cam_w * cam_w)
    good = good & (jnp.sum(cam_w > MIN_VIEW_WEIGHT, axis=-1) >= 2)
    pts = jnp.where(good[:, None], pts * MM_PER_M, jnp.nan)
    cam_w = jnp.where(good[:, None], cam_w, 0.0)
    return pts, cam_w


def _pair_table(c: int) -> np.ndarray:
    """(C, C-1) indices into the pair list of the pairs that contain each camera."""
    pi, pj = camera_pairs(c)
    rows = [[k for k in range(len(pi)) if cam in (pi[k], pj[k])] for cam in range(c)]
    if c < 2:
        return np.zeros((c, 1), dtype=np.int32)
    return np.array(rows, dtype=np.int32)


# ----------------------------------------------------------------------------- public API


def _aligned(detections: MultiViewKeypoints, rig: Rig) -> tuple[np.ndarray, CameraArrays]:
    """Check the inputs and return keypoints (C, T*J, 3) and the matching camera arrays."""
    sub = rig.subset(detections.camera_names)  # ValueError naming cameras not in the calibration
    if len(sub) < 2:
        raise ValueError(f"triangulation needs at least 2 cameras, got {list(detections.camera_names)}")
    kp = detections.one_person
    if np.isinf(kp).any():
        cam = detections.camera_names[int(np.argwhere(np.isinf(kp))[0, 0])]
        raise ValueError(f"keypoints: camera {cam!r} has infinite values")
    c, t, j, _ = kp.shape
    return kp.reshape(c, t * j, 3), camera_arrays(sub)


def _result(method: str, detections: MultiViewKeypoints, pts, cam_w) -> Reconstruction:
    """The triangulation as a :class:`Reconstruction`: ``camera_weights`` (C, T, J) the weight each view had
    in the final DLT (0 = unused); ``quality`` (T, J) their sum where a point was found (else 0)."""
    c, t, _, j = detections.shape
    points = np.asarray(pts, dtype=np.float64).reshape(t, j, 3)
    weights = np.asarray(cam_w, dtype=np.float64).reshape(c, t, j)
    quality = np.where(np.isfinite(points[..., 0]), weights.sum(0), 0.0)
    missing = ~np.isfinite(points[..., 0]).any(0)
    if missing.any():
        names = [detections.skeleton.joint_names[i] for i in np.flatnonzero(missing)]
        log.warning("joints never triangulated (fewer than 2 usable views in every frame): %s", names)
    return Reconstruction(method, points, detections.times_s, detections.skeleton.joint_names,
                          camera_names=detections.camera_names, camera_weights=weights, quality=quality)


def dlt_triangulate(detections: MultiViewKeypoints, rig: Rig, *, min_confidence: float = 0.0) -> Reconstruction:
    """Confidence-weighted DLT (the paper's equation); views with confidence <= min_confidence unused."""
    kp, cams = _aligned(detections, rig)
    conf = np.nan_to_num(kp[..., 2])
    w = np.where(conf > min_confidence, conf, 0.0)
    pts = dlt_arrays(jnp.asarray(kp, jnp.float32), cams, jnp.asarray(w, jnp.float32))
    w_used = np.where(np.isfinite(np.asarray(pts)[:, 0])[None], w, 0.0)
    return _result("dlt", detections, pts, w_used)


def robust_triangulate(
    detections: MultiViewKeypoints, rig: Rig, *, gamma: float = 0.5, sigma_mm: float = 150.0
) -> Reconstruction:
    """The paper's robust triangulation of every frame and joint (see the module docstring)."""
    kp, cams = _aligned(detections, rig)
    pts, cam_w = robust_arrays(jnp.asarray(kp, jnp.float32), cams, gamma=gamma, sigma_mm=sigma_mm)
    return _result("robust", detections, pts, cam_w)
