"""From linked detections to people: triangulate groups, merge split copies, assign by reprojection."""

from __future__ import annotations

import numpy as np
from gaitcap.reconstruction.association.config import AssociationConfig
from gaitcap.reconstruction.association.geometry import ray_distance, triangulate_rays
from gaitcap.reconstruction.association.rays import Rays
from gaitcap.reconstruction.camera import Rig

ROBUST_ITERS = 2  # reweightings of the final triangulation of each person
ROBUST_SCALE_MM = 60.0  # Cauchy scale of the ray-to-point distance
MIRROR_RATIO = 0.5  # a detection is taken as mirrored when that fits at least twice as well as straight


def merge_disjoint_neighbours(points_mm: np.ndarray, comp: np.ndarray, c_: int, p_: int,
                               config: AssociationConfig) -> np.ndarray:
    """Join groups seen by disjoint sets of cameras whose joints lie within ``merge_mm`` (median):
    one person split in two (e.g. two poor two-view triangulations). Returns relabelled (T, N)."""
    t_, k_ = points_mm.shape[:2]
    if k_ < 2:
        return comp
    dist = np.linalg.norm(points_mm[:, :, None] - points_mm[:, None], axis=-1)  # (T, K, K, Ja)
    common = np.isfinite(dist)
    median = nan_median_last(dist)  # a few badly triangulated joints do not keep a person split
    cams = (comp.reshape(t_, c_, p_)[..., None] == np.arange(k_)).any(2).astype(np.float32)  # (T, C, K)
    shared = np.matmul(cams.swapaxes(1, 2), cams)  # (T, K, K) cameras in both groups
    same = (common.sum(-1) >= config.min_joints) & (median < config.merge_mm) & (shared == 0)
    reach = np.maximum(same.astype(np.float32), np.eye(k_, dtype=np.float32))
    for _ in range(int(np.ceil(np.log2(k_)))):
        reach = np.minimum(np.matmul(reach, reach), 1.0)
    rep = np.argmax(reach > 0, axis=-1)  # lowest index of each merged set
    return np.where(comp >= 0, np.take_along_axis(rep, np.maximum(comp, 0), axis=1), -1)


def of_group(flipped: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """(C, T, P, K) flags and (T, N) groups -> (C, T, P) flag of each detection for its own group."""
    c_, t_, p_, _ = flipped.shape
    g = groups.reshape(t_, c_, p_).transpose(1, 0, 2)
    return np.take_along_axis(flipped, np.maximum(g, 0)[..., None], -1)[..., 0] & (g >= 0)


def triangulate_groups(rays: Rays, groups: np.ndarray, *, flipped: np.ndarray | None = None,
                        num_groups: int | None = None, robust_iters: int = 0) -> np.ndarray:
    """Triangulate the association joints of each group of detections -> (T, K, Ja, 3) mm.

    Least squares over the rays, then ``robust_iters`` reweightings (Cauchy, scale
    ``ROBUST_SCALE_MM``) so a misplaced joint in one view does not drag the point. ``flipped`` (C, T, P) marks detections mirrored left/right; their joints are un-mirrored first.
    """
    c_, t_, p_, ja, _ = rays.dirs.shape
    k_ = num_groups if num_groups is not None else max(int(groups.max()) + 1, 1)
    onehot = (groups[:, None, :] == np.arange(k_)[None, :, None]).astype(np.float64)  # (T, K, N)
    dirs, mask = rays.dirs, rays.mask
    if flipped is not None:
        dirs = np.where(flipped[..., None, None], dirs[..., rays.flip, :], dirs)
        mask = np.where(flipped[..., None], mask[..., rays.flip], mask)
    mask = mask.transpose(1, 0, 2, 3).reshape(t_, c_ * p_, ja)
    weights = onehot[..., None] * mask[:, None].astype(np.float64)  # (T, K, N, Ja)
    dirs = dirs.transpose(1, 0, 2, 3, 4).reshape(t_, c_ * p_, ja, 3)
    origins = np.repeat(rays.origins_mm, p_, axis=0)
    points, _ = triangulate_rays(origins, dirs, weights)
    own = np.maximum(groups, 0)[..., None, None]  # (T, N, 1, 1): each detection's own group
    for _ in range(robust_iters):  # down-weight rays far from their point (misplaced joints)
        mine = np.take_along_axis(points, np.broadcast_to(own, (t_, c_ * p_, ja, 3)), axis=1)
        off = np.nan_to_num(ray_distance(origins, dirs, mine), nan=0.0)  # (T, N, Ja)
        points, _ = triangulate_rays(origins, dirs, weights / (1.0 + (off / ROBUST_SCALE_MM) ** 2)[:, None])
    return points


def reprojection_cost(rig: Rig, rays: Rays, points_mm: np.ndarray, config) -> tuple[np.ndarray, np.ndarray]:
    """(C, T, P, K) median reprojection error of person k's joints against detection p, divided by the
    detection's box diagonal; inf where fewer than ``min_joints`` joints compare or above the gate.

    A detection mirrored left/right by the detector is compared mirrored too (the smaller cost counts);
    the second result (C, T, P, K) bool says where the mirrored comparison won clearly (its error below
    ``MIRROR_RATIO`` times the straight one's): a person seen from the side looks almost the same both
    ways round, and noise must not turn them.
    """
    proj = rig.project(points_mm)  # (C, T, K, Ja, 2)
    straight = _median_cost(rays, proj, config)
    mirrored = _median_cost(rays, proj[..., rays.flip, :], config)
    return np.minimum(straight, mirrored), mirrored < MIRROR_RATIO * straight


def nan_median_last(values: np.ndarray) -> np.ndarray:
    """Median over the last axis ignoring NaN (NaN where all are NaN), by one sort."""
    n = np.isfinite(values).sum(-1)
    srt = np.sort(values, axis=-1)  # NaN last
    lo = np.take_along_axis(srt, (np.maximum(n - 1, 0) // 2)[..., None], -1)[..., 0]
    hi = np.take_along_axis(srt, np.minimum(n // 2, values.shape[-1] - 1)[..., None], -1)[..., 0]
    return np.where(n > 0, (lo + hi) / 2, np.nan)


def _median_cost(rays: Rays, proj: np.ndarray, config) -> np.ndarray:
    diff = np.clip(rays.pixels_px[:, :, :, None] - proj[:, :, None], -1e6, 1e6).astype(np.float32)
    err = np.sqrt((diff * diff).sum(-1))  # (C, T, P, K, Ja)
    n = np.isfinite(err).sum(-1)
    with np.errstate(invalid="ignore"):
        cost = nan_median_last(err) / np.maximum(rays.scale_px, 1.0)[..., None]
        ok = (n >= config.min_joints) & (cost < config.reprojection_gate)
    return np.where(ok, cost, np.inf)


def absorb_explained(comp: np.ndarray, cost: np.ndarray) -> np.ndarray:
    """Relabel a group into a larger one when each explains most of the other's detections.

    A person whose detections split into two groups (e.g. different joints visible) yields two
    triangulations of one person, each reprojecting onto the other's detections. Asking both ways
    keeps apart two people who merely overlap in some views.
    Args: comp (T, N) group of each detection; cost (C, T, P, K) from :func:`reprojection_cost`.
    """
    c_, t_, p_, k_ = cost.shape
    if k_ < 2:
        return comp
    onehot = (comp[..., None] == np.arange(k_)).astype(np.float32)  # (T, N, K)
    fits = np.isfinite(cost).transpose(1, 0, 2, 3).reshape(t_, c_ * p_, k_).astype(np.float32)
    explained = np.matmul(onehot.swapaxes(1, 2), fits)  # (T, K_small, K_big): members of l fitting k
    size = onehot.sum(1)  # (T, K)
    bigger = (size[:, None, :] > size[:, :, None]) | (
        (size[:, None, :] == size[:, :, None]) & (np.arange(k_)[None, :] < np.arange(k_)[:, None]))
    majority = explained > 0.5 * size[:, :, None]  # [t, l, k]: most of l's detections fit k
    absorb = bigger & majority & majority.swapaxes(1, 2) & (size[:, :, None] > 0)
    score = np.where(absorb, size[:, None, :], -1.0)
    target = np.where(absorb.any(-1), np.argmax(score, -1), np.arange(k_))  # (T, K)
    for _ in range(2):  # follow chains a -> b -> c
        target = np.take_along_axis(target, target, axis=1)
    return np.where(comp >= 0, np.take_along_axis(target, np.maximum(comp, 0), axis=1), -1)


def prefer_linked(cost: np.ndarray, comp: np.ndarray) -> np.ndarray:
    """Detections already linked to a group by 3D agreement go to that group first (cost - 1) when
    its reprojection also fits; the others compete by reprojection alone."""
    c_, t_, p_, k_ = cost.shape
    own = comp.reshape(t_, c_, p_).transpose(1, 0, 2)[..., None] == np.arange(k_)  # (C, T, P, K)
    return np.where(own & np.isfinite(cost), cost - 1.0, cost)


def assign_greedy(cost: np.ndarray) -> np.ndarray:
    """Per camera and frame, detections to people by increasing cost, one each -> (C, T, P), -1 none."""
    cost = cost.copy()
    c_, t_, p_, k_ = cost.shape
    labels = np.full((c_, t_, p_), -1)
    ci, ti = np.meshgrid(np.arange(c_), np.arange(t_), indexing="ij")
    for _ in range(min(p_, k_)):
        flat = cost.reshape(c_, t_, p_ * k_)
        best = np.argmin(flat, axis=-1)
        val = np.take_along_axis(flat, best[..., None], -1)[..., 0]
        hit = np.isfinite(val)
        p, k = best // k_, best % k_
        labels[ci[hit], ti[hit], p[hit]] = k[hit]
        cost[ci[hit], ti[hit], p[hit], :] = np.inf
        cost[ci[hit], ti[hit], :, k[hit]] = np.inf
    return labels
