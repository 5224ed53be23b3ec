"""Per-frame cross-view association: which 2D detections in which cameras are the same person.

Method (closed-form array maths over the whole clip; the only loops are over a few assignment rounds):

1. Every confident joint of every detection becomes a world ray.
2. Every pair of detections in two different cameras is a hypothesis; its rays are intersected in
   closed form joint by joint. A hypothesis holds when enough joints' rays pass within
   ``ray_gap_mm`` of each other (in front of both cameras); its 3D root is the mean of those midpoints.
3. Each detection's 3D position is the consensus of the roots of its holding hypotheses (one per
   partner detection): the densest cluster. Pairs of the same person all land on that person; chance
   matches between different people (frequent for people side by side: with cameras at one height,
   horizontal offsets hardly show in the epipolar geometry) land elsewhere, scattered.
4. Detections linked by a holding hypothesis whose root agrees with both detections' positions
   (within ``consensus_radius_mm``) are joined; connected components are the people of that frame (a
   camera with two detections in one component is left out of that person's first triangulation).
   Components seen by disjoint cameras whose joints nearly coincide are one person split in two and
   are merged; a component whose detections another component's reprojection explains is absorbed.
5. Each person's association joints are triangulated from its rays, then every camera's detections are
   assigned to people by reprojection error (greedy, one detection per person and camera, gated
   relative to the detection's size), and the people are triangulated again from the final assignment.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from reconstruction.association.geometry import (
    pixel_rays,
    ray_distance,
    triangulate_rays,
    two_ray_closest,
)
from reconstruction.association.multi import MultiPersonDetections
from reconstruction.camera import Rig
from reconstruction.skeletons import Skeleton

ROBUST_ITERS = 2
CHUNK_ELEMENTS = 5e6  # frames x detections^3 per chunk (memory of the consensus step)
ROBUST_SCALE_MM = 60.0
DEFAULT_ASSOCIATION_JOINTS: tuple[str, ...] = (
    "nose", "left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist",
    "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle",
)


@dataclass(frozen=True)
class AssociationConfig:
    """Settings of the per-frame association.

    Attributes:
        confidence_threshold: keypoints at or below this confidence are ignored.
        joints: joint names used to associate (None: the body joints above that the skeleton has).
        ray_gap_mm: two rays of the same joint agree when they pass within this distance.
        min_joints: a detection needs this many confident association joints; a hypothesis this many
            agreeing joints.
        min_inlier_fraction: fraction of the shared joints that must agree for a hypothesis to hold.
        consensus_radius_mm: hypotheses (pairs of detections) whose 3D roots lie within this distance
            agree; a pair links two detections when its root is this near both their consensus positions.
        merge_mm: groups seen by different cameras whose joints lie this close on average (mm) are
            one person.
        reprojection_gate: a detection joins a person when its median reprojection error is below
            this fraction of the detection's box diagonal.
        min_views: people seen by fewer cameras are dropped.
    """

    confidence_threshold: float = 0.3
    joints: tuple[str, ...] | None = None
    ray_gap_mm: float = 120.0
    min_joints: int = 4
    min_inlier_fraction: float = 0.6
    consensus_radius_mm: float = 120.0
    merge_mm: float = 300.0
    reprojection_gate: float = 0.1
    min_views: int = 2

    def __post_init__(self) -> None:
        for name in ("ray_gap_mm", "consensus_radius_mm", "merge_mm", "reprojection_gate"):
            if not getattr(self, name) > 0:
                raise ValueError(f"AssociationConfig.{name} must be > 0, got {getattr(self, name)}")
        if self.min_joints < 1 or self.min_views < 2:
            raise ValueError("AssociationConfig: min_joints must be >= 1 and min_views >= 2")
        if not 0 < self.min_inlier_fraction <= 1:
            raise ValueError("AssociationConfig.min_inlier_fraction must lie in (0, 1]")

    def joint_indices(self, skeleton: Skeleton) -> tuple[int, ...]:
        """Indices of the association joints in ``skeleton`` (ValueError naming unknown joints)."""
        if self.joints is not None:
            missing = [j for j in self.joints if not skeleton.has(j)]
            if missing:
                raise ValueError(f"AssociationConfig.joints: skeleton {skeleton.name} has no {missing}")
            return tuple(skeleton.index(j) for j in self.joints)
        found = tuple(skeleton.index(j) for j in DEFAULT_ASSOCIATION_JOINTS if skeleton.has(j))
        return found if len(found) >= self.min_joints else tuple(range(skeleton.num_joints))


@dataclass(frozen=True, eq=False)
class FramePeople:
    """People found in each frame, not yet linked over time.

    Attributes:
        labels: (C, T, P) int: person index k (within frame t) of detection (c, t, p), -1 for none.
        points_mm: (T, K, Ja, 3) association joints of each person, NaN where absent.
        root_mm: (T, K, 3) mean of the person's association joints, NaN where absent.
        views: (T, K) number of cameras assigned to each person (0 where absent).
        joint_indices: (Ja,) skeleton indices of the association joints.
    """

    labels: np.ndarray
    points_mm: np.ndarray
    root_mm: np.ndarray
    views: np.ndarray
    joint_indices: tuple[int, ...]


@dataclass(frozen=True)
class _Rays:
    origins_mm: np.ndarray  # (C, 3)
    dirs: np.ndarray  # (C, T, P, Ja, 3)
    mask: np.ndarray  # (C, T, P, Ja)
    pixels_px: np.ndarray  # (C, T, P, Ja, 2), NaN where not confident
    flip: np.ndarray  # (Ja,) index of each association joint's left/right mirror among them
    scale_px: np.ndarray  # (C, T, P) box diagonal of the detection


def associate_frames(multi: MultiPersonDetections, rig: Rig, config: AssociationConfig) -> FramePeople:
    """Group each frame's detections into people (see the module docstring for the method).

    Frames are independent here; long clips with many detections per frame are done in chunks of
    frames so the (frames x detections^3) consensus arrays stay within ``CHUNK_ELEMENTS``.
    """
    c_, t_, p_, _ = multi.shape
    chunk = max(1, int(CHUNK_ELEMENTS // max((c_ * p_) ** 3, 1)))
    if t_ <= chunk:
        return _associate_chunk(multi, rig, config)
    parts = []
    for start in range(0, t_, chunk):
        sl = slice(start, min(start + chunk, t_))
        part = MultiPersonDetections(multi.keypoints[:, sl], multi.camera_names, multi.times_s[sl],
                                     multi.skeleton)
        parts.append(_associate_chunk(part, rig, config))
    return _concatenate(parts)


def _concatenate(parts: list[FramePeople]) -> FramePeople:
    k_ = max(p.views.shape[1] for p in parts)

    def pad(a: np.ndarray, fill) -> np.ndarray:
        width = [(0, 0)] * a.ndim
        width[1] = (0, k_ - a.shape[1])
        return np.pad(a, width, constant_values=fill)

    return FramePeople(
        labels=np.concatenate([p.labels for p in parts], axis=1),
        points_mm=np.concatenate([pad(p.points_mm, np.nan) for p in parts]),
        root_mm=np.concatenate([pad(p.root_mm, np.nan) for p in parts]),
        views=np.concatenate([pad(p.views, 0) for p in parts]),
        joint_indices=parts[0].joint_indices,
    )


def _associate_chunk(multi: MultiPersonDetections, rig: Rig, config: AssociationConfig) -> FramePeople:
    rig = rig.subset(multi.camera_names)
    jidx = config.joint_indices(multi.skeleton)
    rays = _rays(multi, rig, jidx, config)
    hyp_ok, hyp_root, hyp_gap = _hypotheses(rays, config)
    node_root = _node_roots(hyp_ok, hyp_root, hyp_gap, config)
    comp = _components(hyp_ok, hyp_root, node_root, config)  # (T, N) component index or -1
    c_, t_, p_ = rays.mask.shape[:3]
    comp = _drop_same_camera_conflicts(comp, c_, p_)
    points = _triangulate_groups(rays, comp)
    if points.shape[1] == 0:
        return _nobody(c_, t_, p_, len(jidx), jidx)
    comp = _merge_disjoint_neighbours(points, comp, c_, p_, config)
    points = _triangulate_groups(rays, comp, num_groups=points.shape[1])
    cost, flipped = _reprojection_cost(rig, rays, points, config)
    comp = _absorb_explained(comp, cost)
    points = _triangulate_groups(rays, comp, flipped=_of_group(flipped, comp), num_groups=points.shape[1],
                                 robust_iters=1)
    cost, flipped = _reprojection_cost(rig, rays, points, config)
    labels = _assign_greedy(_prefer_linked(cost, comp))
    final = labels.transpose(1, 0, 2).reshape(t_, c_ * p_)
    points = _triangulate_groups(rays, final, flipped=_of_group(flipped, final), num_groups=points.shape[1],
                                 robust_iters=ROBUST_ITERS)
    views = np.stack([(labels == k).any(-1).sum(0) for k in range(points.shape[1])], -1)  # (T, K)
    absent = views < config.min_views
    points[absent] = np.nan
    frame = np.broadcast_to(np.arange(t_)[None, :, None], labels.shape)
    labels = np.where((labels >= 0) & absent[frame, np.maximum(labels, 0)], -1, labels)
    views = np.where(absent, 0, views)
    with np.errstate(invalid="ignore"), _quiet():
        root = np.nanmean(points, axis=2)
    return FramePeople(labels=labels, points_mm=points, root_mm=root, views=views, joint_indices=jidx)


def _nobody(c_: int, t_: int, p_: int, ja: int, jidx) -> FramePeople:
    return FramePeople(labels=np.full((c_, t_, p_), -1), points_mm=np.full((t_, 0, ja, 3), np.nan),
                       root_mm=np.full((t_, 0, 3), np.nan), views=np.zeros((t_, 0), int), joint_indices=jidx)


class _quiet:
    """Silence numpy's 'mean of empty slice' warnings inside a block."""

    def __enter__(self):
        import warnings

        self._cm = warnings.catch_warnings()
        self._cm.__enter__()
        warnings.simplefilter("ignore", category=RuntimeWarning)

    def __exit__(self, *exc):
        return self._cm.__exit__(*exc)


def _rays(multi: MultiPersonDetections, rig: Rig, jidx, config: AssociationConfig) -> _Rays:
    conf_all = multi.confident(config.confidence_threshold)  # (C, T, P, J)
    kp = multi.keypoints
    xy = np.where(conf_all[..., None], kp[..., :2], np.nan)
    with _quiet():
        span = np.nanmax(xy, axis=3) - np.nanmin(xy, axis=3)  # (C, T, P, 2)
    scale = np.hypot(span[..., 0], span[..., 1])
    mask = conf_all[:, :, :, jidx]
    mask &= (mask.sum(-1) >= config.min_joints)[..., None]
    pixels = np.where(mask[..., None], kp[:, :, :, jidx, :2], np.nan)
    origins, dirs = pixel_rays(rig, pixels)
    perm = multi.skeleton.flip_permutation
    flip = np.array([jidx.index(perm[j]) if perm[j] in jidx else i for i, j in enumerate(jidx)])
    return _Rays(origins_mm=origins, dirs=dirs, mask=mask, pixels_px=pixels, flip=flip,
                 scale_px=np.nan_to_num(scale, nan=0.0))


def _hypotheses(rays: _Rays, config: AssociationConfig) -> tuple[np.ndarray, np.ndarray]:
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


def _node_roots(ok: np.ndarray, root: np.ndarray, gap: np.ndarray, config: AssociationConfig) -> np.ndarray:
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


def _components(ok: np.ndarray, hyp_root: np.ndarray, node_root: np.ndarray,
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


def _drop_same_camera_conflicts(comp: np.ndarray, c_: int, p_: int) -> np.ndarray:
    """Leave out of a component every camera that contributes two or more detections to it."""
    t_ = comp.shape[0]
    k_ = max(int(comp.max()) + 1, 1)
    onehot = comp.reshape(t_, c_, p_)[..., None] == np.arange(k_)  # (T, C, P, K)
    clash = onehot.sum(2) >= 2  # (T, C, K)
    bad = (onehot & clash[:, :, None, :]).any(-1).reshape(t_, c_ * p_)
    return np.where(bad, -1, comp)


def _merge_disjoint_neighbours(points_mm: np.ndarray, comp: np.ndarray, c_: int, p_: int,
                               config: AssociationConfig) -> np.ndarray:
    """Join groups seen by disjoint sets of cameras whose joints lie within ``merge_mm`` (median):
    one person split in two (e.g. two poor two-view triangulations). Returns relabelled (T, N)."""
    t_, k_ = points_mm.shape[:2]
    if k_ < 2:
        return comp
    dist = np.linalg.norm(points_mm[:, :, None] - points_mm[:, None], axis=-1)  # (T, K, K, Ja)
    common = np.isfinite(dist)
    mean = _nan_median_last(dist)  # median: a few badly triangulated joints do not split a person
    cams = (comp.reshape(t_, c_, p_)[..., None] == np.arange(k_)).any(2).astype(np.float32)  # (T, C, K)
    shared = np.matmul(cams.swapaxes(1, 2), cams)  # (T, K, K) cameras in both groups
    same = (common.sum(-1) >= config.min_joints) & (mean < config.merge_mm) & (shared == 0)
    reach = np.maximum(same.astype(np.float32), np.eye(k_, dtype=np.float32))
    for _ in range(int(np.ceil(np.log2(k_)))):
        reach = np.minimum(np.matmul(reach, reach), 1.0)
    rep = np.argmax(reach > 0, axis=-1)  # lowest index of each merged set
    return np.where(comp >= 0, np.take_along_axis(rep, np.maximum(comp, 0), axis=1), -1)


def _of_group(flipped: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """(C, T, P, K) flags and (T, N) groups -> (C, T, P) flag of each detection for its own group."""
    c_, t_, p_, _ = flipped.shape
    g = groups.reshape(t_, c_, p_).transpose(1, 0, 2)
    return np.take_along_axis(flipped, np.maximum(g, 0)[..., None], -1)[..., 0] & (g >= 0)


def _triangulate_groups(rays: _Rays, groups: np.ndarray, *, flipped: np.ndarray | None = None,
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


def _reprojection_cost(rig: Rig, rays: _Rays, points_mm: np.ndarray, config) -> tuple[np.ndarray, np.ndarray]:
    """(C, T, P, K) median reprojection error of person k's joints against detection p, divided by the
    detection's box diagonal; inf where fewer than ``min_joints`` joints compare or above the gate.

    A detection mirrored left/right by the detector is compared mirrored too (the smaller cost counts);
    the second result (C, T, P, K) bool says where the mirrored comparison won.
    """
    proj = rig.project(points_mm)  # (C, T, K, Ja, 2)
    straight = _median_cost(rays, proj, config)
    mirrored = _median_cost(rays, proj[..., rays.flip, :], config)
    return np.minimum(straight, mirrored), mirrored < straight


def _nan_median_last(values: np.ndarray) -> np.ndarray:
    """Median over the last axis ignoring NaN (NaN where all are NaN), by one sort."""
    n = np.isfinite(values).sum(-1)
    srt = np.sort(values, axis=-1)  # NaN last
    lo = np.take_along_axis(srt, (np.maximum(n - 1, 0) // 2)[..., None], -1)[..., 0]
    hi = np.take_along_axis(srt, np.minimum(n // 2, values.shape[-1] - 1)[..., None], -1)[..., 0]
    return np.where(n > 0, (lo + hi) / 2, np.nan)


def _median_cost(rays: _Rays, proj: np.ndarray, config) -> np.ndarray:
    diff = np.clip(rays.pixels_px[:, :, :, None] - proj[:, :, None], -1e6, 1e6).astype(np.float32)
    err = np.sqrt((diff * diff).sum(-1))  # (C, T, P, K, Ja)
    n = np.isfinite(err).sum(-1)
    with np.errstate(invalid="ignore"):
        cost = _nan_median_last(err) / np.maximum(rays.scale_px, 1.0)[..., None]
        ok = (n >= config.min_joints) & (cost < config.reprojection_gate)
    return np.where(ok, cost, np.inf)


def _absorb_explained(comp: np.ndarray, cost: np.ndarray) -> np.ndarray:
    """Relabel a group into a larger one when each explains most of the other's detections.

    A person whose detections split into two groups (e.g. different joints visible) yields two
    triangulations of one person, each reprojecting onto the other's detections. Asking both ways
    keeps apart two people who merely overlap in some views.
    Args: comp (T, N) group of each detection; cost (C, T, P, K) from :func:`_reprojection_cost`.
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


def _prefer_linked(cost: np.ndarray, comp: np.ndarray) -> np.ndarray:
    """Detections already linked to a group by 3D agreement go to that group first (cost - 1) when
    its reprojection also fits; the others compete by reprojection alone."""
    c_, t_, p_, k_ = cost.shape
    own = comp.reshape(t_, c_, p_).transpose(1, 0, 2)[..., None] == np.arange(k_)  # (C, T, P, K)
    return np.where(own & np.isfinite(cost), cost - 1.0, cost)


def _assign_greedy(cost: np.ndarray) -> np.ndarray:
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
