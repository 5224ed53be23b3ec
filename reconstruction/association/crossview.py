"""Per-frame cross-view association: which 2D detections in which cameras are the same person.

Method (closed-form array maths over the whole clip; the only loops are over a few assignment rounds):

1. Every confident joint of every detection becomes a world ray.
2. Every pair of detections in two different cameras is a hypothesis; its rays are intersected in
   closed form joint by joint. A hypothesis holds when enough joints' rays pass within
   ``ray_gap_mm`` of each other (in front of both cameras); its 3D root is the mean of those midpoints.
3. Each detection's 3D position is the median of the roots of its holding hypotheses (one per partner
   view), which outvotes chance matches between different people.
4. Detections linked by a holding hypothesis whose positions agree within ``merge_radius_mm`` are
   joined; connected components are the people of that frame (at most one detection per camera is
   trusted for a person's 3D points: a camera with two detections in one component is left out).
5. Each person's association joints are triangulated from its rays, then every camera's detections are
   assigned to people by reprojection error (greedy, one detection per person and camera, gated
   relative to the detection's size), and the people are triangulated again from the final assignment.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from reconstruction.association.geometry import pixel_rays, triangulate_rays, two_ray_closest
from reconstruction.association.multi import MultiPersonDetections
from reconstruction.camera import Rig
from reconstruction.skeletons import Skeleton

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
        merge_radius_mm: detections whose 3D positions lie within this distance may be one person.
        reprojection_gate: a detection joins a person when its mean reprojection error is below this
            fraction of the detection's box diagonal.
        min_views: people seen by fewer cameras are dropped.
    """

    confidence_threshold: float = 0.3
    joints: tuple[str, ...] | None = None
    ray_gap_mm: float = 120.0
    min_joints: int = 4
    min_inlier_fraction: float = 0.6
    merge_radius_mm: float = 250.0
    reprojection_gate: float = 0.2
    min_views: int = 2

    def __post_init__(self) -> None:
        for name in ("ray_gap_mm", "merge_radius_mm", "reprojection_gate"):
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
    scale_px: np.ndarray  # (C, T, P) box diagonal of the detection


def associate_frames(multi: MultiPersonDetections, rig: Rig, config: AssociationConfig) -> FramePeople:
    """Group each frame's detections into people (see the module docstring for the method)."""
    rig = rig.subset(multi.camera_names)
    jidx = config.joint_indices(multi.skeleton)
    rays = _rays(multi, rig, jidx, config)
    hyp_ok, hyp_root = _hypotheses(rays, config)
    node_root = _node_roots(hyp_ok, hyp_root)
    comp = _components(hyp_ok, node_root, config)  # (T, N) component index or -1
    c_, t_, p_ = rays.mask.shape[:3]
    comp = _drop_same_camera_conflicts(comp, c_, p_)
    points = _triangulate_groups(rays, comp)
    labels = _assign_by_reprojection(rig, rays, points, config)
    final = labels.transpose(1, 0, 2).reshape(t_, c_ * p_)
    points = _triangulate_groups(rays, final, num_groups=points.shape[1])
    views = np.stack([(labels == k).any(-1).sum(0) for k in range(points.shape[1])], -1)  # (T, K)
    absent = views < config.min_views
    points[absent] = np.nan
    frame = np.broadcast_to(np.arange(t_)[None, :, None], labels.shape)
    labels = np.where((labels >= 0) & absent[frame, np.maximum(labels, 0)], -1, labels)
    views = np.where(absent, 0, views)
    with np.errstate(invalid="ignore"), _quiet():
        root = np.nanmean(points, axis=2)
    return FramePeople(labels=labels, points_mm=points, root_mm=root, views=views, joint_indices=jidx)


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
    return _Rays(origins_mm=origins, dirs=dirs, mask=mask, pixels_px=pixels,
                 scale_px=np.nan_to_num(scale, nan=0.0))


def _hypotheses(rays: _Rays, config: AssociationConfig) -> tuple[np.ndarray, np.ndarray]:
    """All camera pairs x detection pairs.

    Returns:
        ok (C, C, T, P, P) bool (symmetric: ok[a, b, t, p, q] == ok[b, a, t, q, p]) and the
        hypothesis roots (C, C, T, P, P, 3) mm (NaN where not ok).
    """
    c_, t_, p_, ja, _ = rays.dirs.shape
    ia, ib = np.triu_indices(c_, 1)
    o = rays.origins_mm
    w = o[ia] - o[ib]  # (R, 3)
    d = np.nan_to_num(rays.dirs).transpose(0, 1, 3, 2, 4)  # (C, T, Ja, P, 3)
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
    wi = inlier.astype(np.float64)
    # sum over joints of s d1 + u d2 on inlier joints -> (R, T, P, Q, 3)
    sd1 = np.einsum("rtjpq,rtjpx->rtpqx", wi * s, d1, optimize=True)
    ud2 = np.einsum("rtjpq,rtjqx->rtpqx", wi * u, d2, optimize=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        root = (o[ia] + o[ib])[:, None, None, None, :] / 2 + (sd1 + ud2) / (2 * n_in[..., None])
    root[~ok] = np.nan
    ok_full = np.zeros((c_, c_, t_, p_, p_), bool)
    root_full = np.full((c_, c_, t_, p_, p_, 3), np.nan)
    ok_full[ia, ib], ok_full[ib, ia] = ok, ok.swapaxes(-1, -2)
    root_full[ia, ib], root_full[ib, ia] = root, root.swapaxes(2, 3)
    return ok_full, root_full


def _node_roots(ok: np.ndarray, root: np.ndarray) -> np.ndarray:
    """Median over partner views of the hypothesis roots of each detection -> (T, N, 3), N = C * P."""
    c_, _, t_, p_, _ = ok.shape
    r = root.transpose(2, 0, 3, 1, 4, 5).reshape(t_, c_ * p_, c_ * p_, 3)  # (T, N, partners, 3)
    srt = np.sort(r, axis=2)  # NaN last
    n = np.isfinite(r[..., 0]).sum(-1)  # (T, N)
    lo = np.maximum(n - 1, 0) // 2
    hi = np.minimum(n // 2, r.shape[2] - 1)
    a = np.take_along_axis(srt, lo[..., None, None], axis=2)[:, :, 0]
    b = np.take_along_axis(srt, hi[..., None, None], axis=2)[:, :, 0]
    med = (a + b) / 2
    med[n == 0] = np.nan
    return med


def _components(ok: np.ndarray, node_root: np.ndarray, config: AssociationConfig) -> np.ndarray:
    """Connected components of agreeing detections -> (T, N) dense component index or -1."""
    c_, _, t_, p_, _ = ok.shape
    n_ = c_ * p_
    adj = ok.transpose(2, 0, 3, 1, 4).reshape(t_, n_, n_)
    diff = node_root[:, :, None, :] - node_root[:, None, :, :]
    with np.errstate(invalid="ignore"):
        near = (diff * diff).sum(-1) < config.merge_radius_mm**2
    reach = (adj & near).astype(np.float32)
    reach = np.maximum(reach, np.eye(n_, dtype=np.float32))
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


def _triangulate_groups(rays: _Rays, groups: np.ndarray, num_groups: int | None = None) -> np.ndarray:
    """Triangulate the association joints of each group of detections -> (T, K, Ja, 3) mm."""
    c_, t_, p_, ja, _ = rays.dirs.shape
    k_ = num_groups if num_groups is not None else max(int(groups.max()) + 1, 1)
    onehot = (groups[:, None, :] == np.arange(k_)[None, :, None]).astype(np.float64)  # (T, K, N)
    mask = rays.mask.transpose(1, 0, 2, 3).reshape(t_, c_ * p_, ja)
    weights = onehot[..., None] * mask[:, None].astype(np.float64)  # (T, K, N, Ja)
    dirs = rays.dirs.transpose(1, 0, 2, 3, 4).reshape(t_, c_ * p_, ja, 3)
    origins = np.repeat(rays.origins_mm, p_, axis=0)
    points, _ = triangulate_rays(origins, dirs, weights)
    return points


def _assign_by_reprojection(rig: Rig, rays: _Rays, points_mm: np.ndarray, config) -> np.ndarray:
    """Greedy per camera and frame: each detection to the person that reprojects nearest -> (C, T, P)."""
    c_, t_, p_, ja, _ = rays.dirs.shape
    k_ = points_mm.shape[1]
    labels = np.full((c_, t_, p_), -1)
    if k_ == 0:
        return labels
    proj = rig.project(points_mm)  # (C, T, K, Ja, 2)
    err = np.linalg.norm(rays.pixels_px[:, :, :, None] - proj[:, :, None], axis=-1)  # (C, T, P, K, Ja)
    valid = np.isfinite(err)
    n = valid.sum(-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        cost = np.where(valid, err, 0).sum(-1) / n / np.maximum(rays.scale_px, 1.0)[..., None]
    cost = np.where(n >= config.min_joints, cost, np.inf)
    cost = np.where(cost < config.reprojection_gate, cost, np.inf)
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
