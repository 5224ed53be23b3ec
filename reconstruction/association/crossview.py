"""Per-frame cross-view association: which 2D detections in which cameras are the same person.

Method (closed-form array maths over the whole clip; the only loops are over a few assignment rounds);
steps 1 in :mod:`.rays`, 2-4 in :mod:`.hypotheses`, 4-5 in :mod:`.refine`:

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
from gaitcap.reconstruction.association.config import DEFAULT_ASSOCIATION_JOINTS, AssociationConfig
from gaitcap.reconstruction.association.hypotheses import (
    consensus_positions,
    drop_same_camera_conflicts,
    linked_components,
    pair_hypotheses,
)
from gaitcap.reconstruction.association.rays import make_rays, quiet_warnings
from gaitcap.reconstruction.association.refine import (
    ROBUST_ITERS,
    absorb_explained,
    assign_greedy,
    merge_disjoint_neighbours,
    of_group,
    prefer_linked,
    reprojection_cost,
    triangulate_groups,
)
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints

__all__ = ["DEFAULT_ASSOCIATION_JOINTS", "AssociationConfig", "FramePeople", "associate_frames"]

CHUNK_ELEMENTS = 5e6  # frames x detections^3 per chunk (memory of the consensus step)


@dataclass(frozen=True, eq=False)
class FramePeople:
    """People found in each frame, not yet linked over time.

    Attributes:
        labels: (C, T, P) int: person index k (within frame t) of detection (c, t, p), -1 for none.
        points_mm: (T, K, Ja, 3) association joints of each person, NaN where absent.
        root_mm: (T, K, 3) mean of the person's association joints, NaN where absent.
        views: (T, K) number of cameras assigned to each person (0 where absent).
        joint_indices: (Ja,) skeleton indices of the association joints.
        flipped: (C, T, P) bool: detection (c, t, p) is its person mirrored left/right (the detector
            swapped the sides); None: not known (taken as False).
    """

    labels: np.ndarray
    points_mm: np.ndarray
    root_mm: np.ndarray
    views: np.ndarray
    joint_indices: tuple[int, ...]
    flipped: np.ndarray | None = None


def associate_frames(multi: MultiViewKeypoints, rig: Rig, config: AssociationConfig) -> FramePeople:
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
        part = MultiViewKeypoints(multi.keypoints[:, sl], multi.camera_names, multi.times_s[sl],
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
        flipped=np.concatenate([p.flipped for p in parts], axis=1),
    )


def _associate_chunk(multi: MultiViewKeypoints, rig: Rig, config: AssociationConfig) -> FramePeople:
    rig = rig.subset(multi.camera_names)
    jidx = config.joint_indices(multi.skeleton)
    rays = make_rays(multi, rig, jidx, config)
    hyp_ok, hyp_root, hyp_gap = pair_hypotheses(rays, config)
    node_root = consensus_positions(hyp_ok, hyp_root, hyp_gap, config)
    comp = linked_components(hyp_ok, hyp_root, node_root, config)  # (T, N) component index or -1
    c_, t_, p_ = rays.mask.shape[:3]
    comp = drop_same_camera_conflicts(comp, c_, p_)
    points = triangulate_groups(rays, comp)
    if points.shape[1] == 0:
        return _nobody(c_, t_, p_, len(jidx), jidx)
    comp = merge_disjoint_neighbours(points, comp, c_, p_, config)
    points = triangulate_groups(rays, comp, num_groups=points.shape[1])
    cost, flipped = reprojection_cost(rig, rays, points, config)
    comp = absorb_explained(comp, cost)
    points = triangulate_groups(rays, comp, flipped=of_group(flipped, comp), num_groups=points.shape[1],
                                 robust_iters=1)
    cost, flipped = reprojection_cost(rig, rays, points, config)
    labels = assign_greedy(prefer_linked(cost, comp))
    final = labels.transpose(1, 0, 2).reshape(t_, c_ * p_)
    mirrored = of_group(flipped, final)  # (C, T, P)
    points = triangulate_groups(rays, final, flipped=mirrored, num_groups=points.shape[1],
                                 robust_iters=ROBUST_ITERS)
    views = np.stack([(labels == k).any(-1).sum(0) for k in range(points.shape[1])], -1)  # (T, K)
    absent = views < config.min_views
    points[absent] = np.nan
    frame = np.broadcast_to(np.arange(t_)[None, :, None], labels.shape)
    labels = np.where((labels >= 0) & absent[frame, np.maximum(labels, 0)], -1, labels)
    views = np.where(absent, 0, views)
    with np.errstate(invalid="ignore"), quiet_warnings():
        root = np.nanmean(points, axis=2)
    return FramePeople(labels=labels, points_mm=points, root_mm=root, views=views, joint_indices=jidx,
                       flipped=mirrored & (labels >= 0))


def _nobody(c_: int, t_: int, p_: int, ja: int, jidx) -> FramePeople:
    return FramePeople(labels=np.full((c_, t_, p_), -1), points_mm=np.full((t_, 0, ja, 3), np.nan),
                       root_mm=np.full((t_, 0, 3), np.nan), views=np.zeros((t_, 0), int), joint_indices=jidx,
                       flipped=np.zeros((c_, t_, p_), bool))
