"""Pairs of detections in two cameras, their 3D consensus, and the detections they link.

All camera pairs x detection pairs are intersected joint by joint in closed form; a pair holds when
most joints' rays pass within ``ray_gap_mm``. Each detection's position is the densest cluster of its
holding pairs' 3D roots (chance matches between side-by-side people scatter, the person's own pairs
coincide), and detections are linked by pairs that agree with both positions.
"""

from __future__ import annotations

import numpy as np
from gaitcap.reconstruction.association.config import AssociationConfig
from gaitcap.reconstruction.association.geometry import two_ray_closest
from gaitcap.reconstruction.association.rays import Rays


def pair_hypotheses(rays: Rays, config: AssociationConfig) -> tuple[np.ndarray, np.ndarray]:
    """All camera pairs x detection pairs.

    Returns:
        ok (C, C, T, P, P) bool (symmetric: ok[a, b, t, p, q] == ok[b, a, t, q, p]), the
        hypothesis roots (C, C, T, P, P, 3) mm and the mean ray gap of the agreeing joints
        (C, C, T, P, P) mm (NaN where not ok).
    """
    c_, t_, p_, ja, _ = rays.dirs.shape
    ia, ib = np.triu_indices(c_, 1)
    o = rays.origins_mm
    w = (o[ia] - o[ib]).astype(np.float32)  # (R, 3)
    d = np.nan_to_num(rays.dirs).astype(np.float32).transpose(0, 1, 3, 2, 4)  # (C, T, Ja, P, 3)
    d1, d2 = d[ia], d[ib]  # (R, T, Ja, P, 3)
    dot12 = np.matmul(d1, d2.swapaxes(-1, -2))  # (R, T, Ja, P, Q)
    d1w = np.einsum("rtjpx,rx->rtjp", d1, w)[..., :, None]
    d2w = np.einsum("rtjqx,rx->rtjq", d2, w)[..., None, :]
    sep2 = (w * w).sum(-1)[:, None, None, None, None]
    s, u, gap = two_ray_closest(sep2, d1w, d2w, dot12)
    m = rays.mask.transpose(0, 1, 3, 2)  # (C, T, Ja, P)
    shared = m[ia][..., :, None] & m[ib][..., None, :] & (s > 0) & (u > 0)
    inlier = shared & (gap < config.ray_gap_mm)
    n_shared = shared.sum(2)
    n_in = inlier.sum(2)  # (R, T, P, Q)
    ok = (n_in >= config.min_joints) & (n_in >= config.min_inlier_fraction * n_shared)
    wi = inlier.astype(np.float32)
    # sum over joints of s d1 + u d2 on inlier joints -> (R, T, P, Q, 3)
    sd1 = np.einsum("rtjpq,rtjpx->rtpqx", wi * s, d1, optimize=True)
    ud2 = np.einsum("rtjpq,rtjqx->rtpqx", wi * u, d2, optimize=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        root = (o[ia] + o[ib])[:, None, None, None, :] / 2 + (sd1 + ud2) / (2 * n_in[..., None])
    root[~ok] = np.nan
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_gap = np.where(ok, (np.where(inlier, gap, 0.0)).sum(2) / n_in, np.nan)
    ok_full = np.zeros((c_, c_, t_, p_, p_), bool)
    root_full = np.full((c_, c_, t_, p_, p_, 3), np.nan, np.float32)
    gap_full = np.full((c_, c_, t_, p_, p_), np.nan, np.float32)
    ok_full[ia, ib], ok_full[ib, ia] = ok, ok.swapaxes(-1, -2)
    root_full[ia, ib], root_full[ib, ia] = root, root.swapaxes(2, 3)
    gap_full[ia, ib], gap_full[ib, ia] = mean_gap, mean_gap.swapaxes(-1, -2)
    return ok_full, root_full, gap_full


def consensus_positions(ok: np.ndarray, root: np.ndarray, gap: np.ndarray, config: AssociationConfig) -> np.ndarray:
    """Consensus 3D position of each detection -> (T, N, 3), N = C * P (NaN: no consensus).

    Among the roots of a detection's holding hypotheses (one per partner detection), the one with most
    others within ``consensus_radius_mm`` (ties: smallest ray gap) wins; the consensus is the mean of
    the roots near it. True partners all land on the person; chance matches land elsewhere, scattered.
    """
    c_, _, t_, p_, _ = ok.shape
    n_ = c_ * p_
    r = root.transpose(2, 0, 3, 1, 4, 5).reshape(t_, n_, n_, 3)  # (T, N, partners, 3)
    g = gap.transpose(2, 0, 3, 1, 4).reshape(t_, n_, n_)
    valid = np.isfinite(r[..., 0])
    # invalid roots go to distinct far-away spots, so "near" needs no validity masks
    far = np.zeros((n_, 3), np.float32)
    far[:, 0] = 1e6 * np.arange(1, n_ + 1)
    rz = np.where(valid[..., None], r, far).astype(np.float32)
    sq = (rz * rz).sum(-1)
    d2 = sq[..., :, None] + sq[..., None, :] - 2 * np.matmul(rz, rz.swapaxes(-1, -2))
    near = d2 < config.consensus_radius_mm**2
    count = np.count_nonzero(near, axis=-1)  # (T, N, partners)
    score = np.where(valid, count - np.clip(np.nan_to_num(g, nan=1e9) / config.ray_gap_mm, 0, 0.99), -1.0)
    best = np.argmax(score, axis=-1)  # (T, N)
    members = np.take_along_axis(near, best[..., None, None], axis=2) & valid[:, :, None, :]  # (T, N, 1, P)
    n = np.count_nonzero(members, axis=(-2, -1))
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.matmul(members.astype(np.float32), np.where(valid[..., None], rz, 0))[:, :, 0] / n[..., None]
    out[n == 0] = np.nan
    return out


def linked_components(ok: np.ndarray, hyp_root: np.ndarray, node_root: np.ndarray,
                config: AssociationConfig) -> np.ndarray:
    """Connected components of agreeing detections -> (T, N) dense component index or -1.

    Two detections are linked when their hypothesis holds and its root lies within
    ``consensus_radius_mm`` of both detections' consensus positions.
    """
    c_, _, t_, p_, _ = ok.shape
    n_ = c_ * p_
    h = hyp_root.transpose(2, 0, 3, 1, 4, 5).reshape(t_, n_, n_, 3)
    r2 = config.consensus_radius_mm**2
    with np.errstate(invalid="ignore"):
        near_a = ((h - node_root[:, :, None, :]) ** 2).sum(-1) < r2
        near_b = ((h - node_root[:, None, :, :]) ** 2).sum(-1) < r2
    adj = ok.transpose(2, 0, 3, 1, 4).reshape(t_, n_, n_) & near_a & near_b
    reach = np.maximum(adj.astype(np.float32), np.eye(n_, dtype=np.float32))
    for _ in range(int(np.ceil(np.log2(max(n_, 2))))):
        reach = np.minimum(np.matmul(reach, reach), 1.0)
    first = np.argmax(reach > 0, axis=-1)  # smallest member index = component label
    size = reach.sum(-1)
    is_head = (first == np.arange(n_)) & (size >= 2)
    dense = np.cumsum(is_head, axis=1) - 1  # (T, N)
    comp = np.take_along_axis(dense, first, axis=1)
    member = np.take_along_axis(is_head, first, axis=1)
    return np.where(member, comp, -1)


def drop_same_camera_conflicts(comp: np.ndarray, c_: int, p_: int) -> np.ndarray:
    """Leave out of a component every camera that contributes two or more detections to it."""
    t_ = comp.shape[0]
    k_ = max(int(comp.max()) + 1, 1)
    onehot = comp.reshape(t_, c_, p_)[..., None] == np.arange(k_)  # (T, C, P, K)
    clash = onehot.sum(2) >= 2  # (T, C, K)
    bad = (onehot & clash[:, :, None, :]).any(-1).reshape(t_, c_ * p_)
    return np.where(bad, -1, comp)
