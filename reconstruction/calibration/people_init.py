"""Calibration from people alone (no board): the camera poses from a walk, the scale from the subject's
entered height, the world frame from the floor the feet stand on.

1. Poses: the camera with the most confident keypoints is the root; each other camera is placed, best
   connected first, from the essential matrix of the keypoints it shares (same frame, same joint) with a
   camera already placed (RANSAC, OpenCV), its baseline scaled to the rig so far by the depths of their
   common points. Intrinsics are taken as given (a separate intrinsics session, or the cameras' data).
2. Scale: the subject's stature chain (ankle - knee - hip - neck - head, each side; each segment's median
   over the walk) is ``STATURE_CHAIN_RATIO`` times the standing height (segment proportions of Drillis and
   Contini's anthropometric table: the ankle's height above the floor, 0.039 H, is the rest), so the rig is
   scaled to make it match ``height_mm``. The short heel - ankle segment is left out: detector noise
   lengthens a short segment most (by 15 mm on the synthetic clinic's feet).
3. Refinement: :func:`gaitcap.reconstruction.calibration.people_bundle.refine_rig_from_people` with a loose
   prior, then the scale is measured and set again.
4. World frame: :func:`gaitcap.reconstruction.calibration.walk_frame.world_from_walk` (floor from the feet
   in stance, x along the walk).

Units: mm, px. Pure computation (numpy, OpenCV geometry, scipy); no I/O.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import cv2
import numpy as np
from gaitcap.reconstruction.calibration.people_bundle import (
    PeopleBundleConfig,
    PeopleBundleReport,
    refine_rig_from_people,
)
from gaitcap.reconstruction.calibration.walk_frame import reframe_rig, world_from_walk
from gaitcap.reconstruction.camera import Rig, matrix_to_rodrigues
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.triangulation import robust_triangulate

log = logging.getLogger(__name__)

STATURE_CHAIN_RATIO = 0.97  # ankle-knee-hip-neck-head over standing height (Drillis & Contini)
CHAIN = ("ankle", "knee", "hip")


@dataclass(frozen=True)
class PeopleCalibrationConfig:
    """Settings of the calibration from people.

    Attributes:
        min_confidence: keypoints at or below this confidence are not used.
        min_shared: a camera needs this many keypoints shared with a placed camera to be placed.
        ransac_px: RANSAC threshold of the essential matrix, px.
        start_baseline_mm: the first baseline's length before the height scales the rig, mm.
        bundle: the refinement (its prior is loose: the poses come from the people themselves); up to 400
            frames of the walk (on the synthetic clinic's 20 s walk: centres within 13.5 mm of the truth, 16.0 mm
            with 150 frames, one seed).
    """

    min_confidence: float = 0.5
    min_shared: int = 100
    ransac_px: float = 4.0
    start_baseline_mm: float = 3000.0
    bundle: PeopleBundleConfig = PeopleBundleConfig(prior_rotation_deg=5.0, prior_shift_mm=300.0, max_frames=400)


@dataclass(frozen=True, eq=False)
class PeopleCalibration:
    """The rig calibrated from people, the scale factor applied last (1 = unchanged), the stature measured
    (mm) and the refinement's report."""

    rig: Rig
    stature_mm: float
    scale_factors: tuple[float, ...]
    report: PeopleBundleReport

    def to_dict(self) -> dict:
        return {"stature_mm": self.stature_mm, "scale_factors": list(self.scale_factors),
                "refinement": self.report.to_dict()}


def _normalized(rig: Rig, det: MultiViewKeypoints, c: int) -> np.ndarray:
    """Undistorted normalised image coordinates (T, J, 2) of camera c's keypoints (NaN where not confident)."""
    cam = rig[c]
    kp = det.one_person[c, ..., :2]
    ok = det.confident()[c, :, 0]
    out = np.full(kp.shape, np.nan)
    if ok.any():
        pts = cv2.undistortPoints(kp[ok].reshape(-1, 1, 2).astype(np.float64), cam.matrix_px, cam.dist)
        out[ok] = pts.reshape(-1, 2)
    return out


def _relative_pose(a: np.ndarray, b: np.ndarray, focal_px: float, ransac_px: float):
    """Pose (R, t unit) of camera b relative to camera a from shared normalised points (N, 2) each."""
    e, mask = cv2.findEssentialMat(a, b, np.eye(3), method=cv2.RANSAC, prob=0.999, threshold=ransac_px / focal_px)
    if e is None:
        raise ValueError("calibration from people: no essential matrix")
    _, rot, t, _ = cv2.recoverPose(e[:3], a, b, np.eye(3), mask=mask)
    return rot, t.ravel()


def _shared(norm: dict[int, np.ndarray], a: int, b: int) -> np.ndarray:
    return np.isfinite(norm[a]).all(-1) & np.isfinite(norm[b]).all(-1)


def _rig_of(rig: Rig, poses: dict[int, tuple[np.ndarray, np.ndarray]]) -> Rig:
    return Rig(tuple(rig[c].replace(rvec=matrix_to_rodrigues(r), tvec_mm=t) for c, (r, t) in sorted(poses.items())))


def _place(det: MultiViewKeypoints, rig: Rig, norm: dict[int, np.ndarray], poses: dict, c: int, via: int,
           config: PeopleCalibrationConfig) -> tuple[np.ndarray, np.ndarray]:
    """World -> camera pose of camera ``c`` from its relative pose to the placed camera ``via``."""
    ok = _shared(norm, via, c)
    rel_r, rel_t = _relative_pose(norm[via][ok], norm[c][ok], float(rig[c].matrix_px[0, 0]), config.ransac_px)
    r_via, t_via = poses[via]
    rot = rel_r @ r_via
    if len(poses) == 1:
        return rot, rel_r @ t_via + config.start_baseline_mm * rel_t
    # scale: depths in camera `via` of the points the placed rig triangulates, against the pair's own
    placed = _rig_of(rig, poses)
    names = [rig[k].name for k in sorted(poses)]
    sub = MultiViewKeypoints.of_one_person(det.one_person[sorted(poses)], tuple(names), det.times_s, det.skeleton)
    pts = robust_triangulate(sub, placed).points_mm
    unit = config.start_baseline_mm * rel_t  # the pair's baseline, before its scale is known
    pair = _rig_of(rig, {via: (np.eye(3), np.zeros(3)), c: (rel_r, unit)})
    pair_det = MultiViewKeypoints.of_one_person(det.one_person[[via, c] if via < c else [c, via]], tuple(pair.names), det.times_s, det.skeleton)
    pair_pts = robust_triangulate(pair_det, pair).points_mm  # in camera via's frame
    depth_rig = (pts @ r_via.T + t_via)[..., 2]
    depth_pair = pair_pts[..., 2]
    both = np.isfinite(depth_rig) & np.isfinite(depth_pair) & (depth_pair > 0) & ok
    if both.sum() < config.min_shared // 4:
        raise ValueError(f"calibration from people: camera {rig[c].name} shares too few triangulated keypoints "
                         f"with the cameras placed ({int(both.sum())})")
    scale = float(np.median(depth_rig[both] / depth_pair[both]))
    return rot, rel_r @ t_via + scale * unit


def initial_poses(det: MultiViewKeypoints, rig: Rig, config: PeopleCalibrationConfig) -> Rig:
    """The rig's cameras placed from the keypoints alone (arbitrary frame and scale); ValueError naming a
    camera that shares too few keypoints with the others."""
    c_count = det.shape[0]
    norm = {c: _normalized(rig, det, c) for c in range(c_count)}
    counts = [int(np.isfinite(norm[c]).all(-1).sum()) for c in range(c_count)]
    root = int(np.argmax(counts))
    poses = {root: (np.eye(3), np.zeros(3))}
    while len(poses) < c_count:
        best = max((int(_shared(norm, p, c).sum()), c, p) for c in range(c_count) if c not in poses for p in poses)
        shared, c, via = best
        if shared < config.min_shared:
            missing = [rig[k].name for k in range(c_count) if k not in poses]
            raise ValueError(f"calibration from people: cameras {missing} share fewer than {config.min_shared} "
                             f"confident keypoints with the cameras placed (best {shared})")
        poses[c] = _place(det, rig, norm, poses, c, via, config)
        log.info("people calibration: placed %s from %s (%d shared keypoints)", rig[c].name, rig[via].name, shared)
    return _rig_of(rig, poses)


def stature_mm(points_mm: np.ndarray, det: MultiViewKeypoints) -> float:
    """Standing height (mm) from the stature chain (ankle-knee-hip-neck-head): each segment's median length
    over the frames, summed, the two sides averaged, divided by ``STATURE_CHAIN_RATIO``; ValueError when a
    joint is missing from the skeleton or a segment is never reconstructed."""
    sk = det.skeleton
    for name in ("neck", "head"):
        if name not in sk.joint_names:
            raise ValueError(f"calibration from people: skeleton {sk.name} has no {name!r} joint for the height")
    sides = []
    for side in ("left", "right"):
        joints = [sk.index(f"{side}_{n}") for n in CHAIN] + [sk.index("neck"), sk.index("head")]
        seg = np.linalg.norm(np.diff(points_mm[:, joints], axis=1), axis=-1)  # (T, segments)
        if not np.isfinite(seg).any(0).all():
            raise ValueError(f"calibration from people: a {side} segment of the ankle-to-head chain was never "
                             f"reconstructed")
        sides.append(np.nanmedian(seg, axis=0).sum())
    return float(np.mean(sides) / STATURE_CHAIN_RATIO)


def _scaled(rig: Rig, factor: float) -> Rig:
    return Rig(tuple(c.replace(tvec_mm=c.tvec_mm * factor) for c in rig))


def _frame(rig: Rig, det: MultiViewKeypoints) -> Rig:
    sk = det.skeleton
    pts = robust_triangulate(det, rig).points_mm
    feet = pts[:, [sk.index(f"{s}_{n}") for s in ("left", "right") for n in ("heel", "big_toe")]]
    pelvis = 0.5 * (pts[:, sk.index("left_hip")] + pts[:, sk.index("right_hip")])
    return reframe_rig(rig, world_from_walk(feet, pelvis))


def calibrate_from_people(det: MultiViewKeypoints, intrinsics: Rig, *, height_mm: float,
                          config: PeopleCalibrationConfig = PeopleCalibrationConfig()) -> PeopleCalibration:
    """A rig from one walk of a subject of standing height ``height_mm`` (mm), seen in ``det`` (C, T, J, 3)
    px; ``intrinsics``: the cameras (their intrinsics are used, their poses ignored)."""
    if not 1000.0 <= height_mm <= 2300.0:
        raise ValueError(f"calibration from people: height_mm must be a standing height in mm, got {height_mm}")
    rig = intrinsics.subset(det.camera_names)
    rig = initial_poses(det, rig, config)
    factors = []
    for _ in range(2):  # scale, refine, scale again
        factor = height_mm / stature_mm(robust_triangulate(det, rig).points_mm, det)
        rig = _scaled(rig, factor)
        factors.append(factor)
        refined = refine_rig_from_people([det], rig, config=config.bundle)
        rig = refined.rig
    factor = height_mm / stature_mm(robust_triangulate(det, rig).points_mm, det)
    rig = _scaled(rig, factor)
    factors.append(factor)
    rig = _frame(rig, det)
    return PeopleCalibration(rig, stature_mm(robust_triangulate(det, rig).points_mm, det), tuple(factors),
                             refined.report)
