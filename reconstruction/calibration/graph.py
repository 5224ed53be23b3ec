"""Initial extrinsics: relative poses of camera pairs from shared board views, chained along a
maximum spanning tree of the camera graph (edge weight = number of agreeing shared views), then an
initial board pose per frame with every view's corner order made consistent across cameras."""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.calibration.geometry import compose, invert, mean_rotation, rotation_angle_deg
from gaitcap.reconstruction.calibration.views import ViewPoses
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import breadth_first_order, connected_components, minimum_spanning_tree

log = logging.getLogger(__name__)

PAIR_ROT_TOL_DEG = 3.0
PAIR_TRANS_TOL_REL = 0.05
FRAME_ROT_TOL_DEG = 10.0
FRAME_TRANS_TOL_MM = 250.0
ASSIGN_ROT_TOL_DEG = 30.0  # a view whose pose is this far off the frame's is left out (orders differ by 180)


@dataclass(frozen=True, eq=False)
class InitialPoses:
    """Camera extrinsics (world = root camera frame) and per-frame board poses.

    Attributes:
        cam_rotation: (C, 3, 3) world -> camera.
        cam_tvec_mm: (C, 3).
        frame_rotation: (F, 3, 3) board -> world (identity for unused frames).
        frame_tvec_mm: (F, 3).
        symmetry: (C, F) int: index of the board symmetry that orders the view's corners; -1 = view unused.
        root: index of the root camera.
    """

    cam_rotation: np.ndarray
    cam_tvec_mm: np.ndarray
    frame_rotation: np.ndarray
    frame_tvec_mm: np.ndarray
    symmetry: np.ndarray
    root: int


def _consensus(rots: np.ndarray, ts: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """Robust mean of relative-pose hypotheses (K, 3, 3), (K, 3): most-supported hypothesis, refined."""
    ang = rotation_angle_deg(rots[:, None], rots[None, :])
    dist = np.linalg.norm(ts[:, None] - ts[None, :], axis=-1)
    tol = PAIR_TRANS_TOL_REL * np.linalg.norm(ts, axis=-1)[:, None]
    agree = (ang < PAIR_ROT_TOL_DEG) & (dist < np.maximum(tol, 20.0))
    best = int(np.argmax(agree.sum(1)))
    inl = agree[best]
    return mean_rotation(rots[inl]), np.median(ts[inl], axis=0), int(inl.sum())


def _pair(poses: ViewPoses, a: int, b: int) -> tuple[np.ndarray, np.ndarray, int] | None:
    """Relative pose b -> a (x_a = R x_b + t) from shared frames; None when they share none."""
    shared = np.flatnonzero(poses.valid[a].any(-1) & poses.valid[b].any(-1))
    if len(shared) == 0:
        return None
    rots, ts = [], []
    for f in shared:
        sa = int(np.argmax(poses.valid[a, f]))
        ra, ta = poses.rotation[a, f, sa], poses.tvec_mm[a, f, sa]
        for sb in np.flatnonzero(poses.valid[b, f]):
            rb_inv, tb_inv = invert(poses.rotation[b, f, sb], poses.tvec_mm[b, f, sb])
            r, t = compose(ra, ta, rb_inv, tb_inv)
            rots.append(r)
            ts.append(t)
    return _consensus(np.array(rots), np.array(ts))


def _spanning_tree(pairs: dict, c_count: int, names: tuple[str, ...]) -> tuple[int, np.ndarray, np.ndarray]:
    """Root, BFS order and predecessors of the maximum spanning tree over shared views."""
    weight = np.zeros((c_count, c_count))
    for (a, b), (_, _, n) in pairs.items():
        weight[a, b] = weight[b, a] = n
    n_comp, labels = connected_components(csr_matrix(weight > 0), directed=False)
    root = int(np.argmax(weight.sum(1)))
    if n_comp > 1:
        lonely = [names[i] for i in range(c_count) if labels[i] != labels[root]]
        raise ValueError(
            f"cameras {lonely} share no board views with cameras {[names[i] for i in range(c_count) if labels[i] == labels[root]]}; "
            "hold the board where each of them and a neighbouring camera see it at the same time"
        )
    cost = np.where(weight > 0, 1.0 / np.maximum(weight, 1e-9), 0.0)
    tree = minimum_spanning_tree(csr_matrix(cost))
    order, pred = breadth_first_order(tree + tree.T, root, directed=False)
    return root, order, pred


def chain_cameras(poses: ViewPoses, names: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray, int]:
    """World (= root camera) -> camera rotations (C, 3, 3), translations (C, 3) mm, and the root."""
    c_count = poses.valid.shape[0]
    pairs = {}
    for a in range(c_count):
        for b in range(a + 1, c_count):
            rel = _pair(poses, a, b)
            if rel is not None and rel[2] > 0:
                pairs[(a, b)] = rel
    root, order, pred = _spanning_tree(pairs, c_count, names)
    rot, tvec = np.tile(np.eye(3), (c_count, 1, 1)), np.zeros((c_count, 3))
    for b in order[1:]:
        a = int(pred[b])
        if (a, b) in pairs:
            r_ab, t_ab, _ = pairs[(a, b)]  # x_a = r_ab x_b + t_ab
            r_ba, t_ba = invert(r_ab, t_ab)
        else:
            r_ba, t_ba, _ = pairs[(b, a)]  # x_b = r_ba x_a + t_ba
        rot[b], tvec[b] = compose(r_ba, t_ba, rot[a], tvec[a])
    return rot, tvec, root


def _frame_init(poses: ViewPoses, f: int, cam_r: np.ndarray, cam_t: np.ndarray, sym: np.ndarray):
    """Board pose in the world for frame f; fills ``sym[:, f]`` with each view's corner order."""
    cams = np.flatnonzero(poses.valid[:, f].any(-1))
    cands = []  # (camera, symmetry, R board->world, t)
    for c in cams:
        ri, ti = invert(cam_r[c], cam_t[c])
        for s in np.flatnonzero(poses.valid[c, f]):
            cands.append((c, s, *compose(ri, ti, poses.rotation[c, f, s], poses.tvec_mm[c, f, s])))
    rots = np.array([x[2] for x in cands])
    ts = np.array([x[3] for x in cands])
    close = (rotation_angle_deg(rots[:, None], rots[None]) < FRAME_ROT_TOL_DEG) & (
        np.linalg.norm(ts[:, None] - ts[None], axis=-1) < FRAME_TRANS_TOL_MM
    )
    cam_of = np.array([x[0] for x in cands])
    support = [len(set(cam_of[close[i]])) for i in range(len(cands))]
    best = int(np.argmax(support))
    angle = rotation_angle_deg(rots, rots[best])
    for c in cams:  # each view's corner order: its candidate turned most like the best-supported pose
        mine = np.flatnonzero(cam_of == c)
        i = int(mine[np.argmin(angle[mine])])
        if angle[i] < ASSIGN_ROT_TOL_DEG:
            sym[c, f] = cands[i][1]
    return cands[best][2], cands[best][3]


def initial_poses(poses: ViewPoses, names: tuple[str, ...]) -> InitialPoses:
    """Chain the cameras, then give every frame an initial board pose and consistent corner orders."""
    cam_r, cam_t, root = chain_cameras(poses, names)
    c_count, f_count = poses.valid.shape[:2]
    sym = np.full((c_count, f_count), -1, dtype=np.int64)
    fr, ft = np.tile(np.eye(3), (f_count, 1, 1)), np.zeros((f_count, 3))
    for f in np.flatnonzero(poses.valid.any(-1).any(0)):
        fr[f], ft[f] = _frame_init(poses, f, cam_r, cam_t, sym)
    dropped = int((poses.valid.any(-1) & (sym < 0)).sum())
    if dropped:
        log.info("initial poses: %d views disagree with the other cameras and are left out", dropped)
    return InitialPoses(cam_r, cam_t, fr, ft, sym, root)
