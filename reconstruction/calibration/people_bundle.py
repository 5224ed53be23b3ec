"""Refinement of a rig from people: bundle adjustment of the camera poses (and optionally focal lengths)
over the 2D keypoints of one or more trials, the board calibration as prior.

Unknowns: per camera a turn (rotation vector, rad, applied after the prior rotation: R = exp(w) R0), a
shift of the centre (mm) and optionally a focal-length scale; per (frame, joint) a 3D point (mm). The prior
holds every camera near its board calibration (``prior_rotation_deg``, ``prior_shift_mm``), which fixes the
world frame and keeps the board's scale: a similarity change of the whole rig would move every camera
against its prior. The same robust loss (soft L1) covers the keypoints and the prior, so a camera that
really moved leaves its prior behind at little cost while the others hold theirs. Detector outliers and
left/right swaps are keypoints far from the others' consensus: the robust loss discounts them and rounds of
rejection (``outlier_sigmas`` robust standard deviations) drop them.

Units: points mm, pixels px, rotations rad inside and deg in settings and reports. Pure computation
(numpy, scipy sparse least squares); no I/O.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.calibration.bundle import RAYLEIGH_MEDIAN
from gaitcap.reconstruction.calibration.compare import RigComparison, compare_rigs
from gaitcap.reconstruction.calibration.geometry import rodrigues_batch, rvec_of
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.triangulation import robust_triangulate
from scipy.optimize import least_squares
from scipy.sparse import coo_matrix

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PeopleBundleConfig:
    """Settings of the refinement from people.

    Attributes:
        min_confidence: keypoints at or below this confidence are not used.
        max_frames: frames used at most per trial (evenly spaced).
        min_views: a (frame, joint) needs this many confident views to enter the adjustment.
        refine_focal: also adjust each camera's focal length (one scale for fx and fy).
        prior_rotation_deg / prior_shift_mm / prior_focal_pct: one standard deviation of the prior.
        robust_scale_px: soft-L1 scale, px.
        outlier_sigmas: keypoints beyond this many robust sigmas are rejected after each round.
        min_outlier_px: never reject keypoints closer than this, px.
        rounds: solve / reject rounds.
    """

    min_confidence: float = 0.5
    max_frames: int = 150
    min_views: int = 3
    refine_focal: bool = False
    prior_rotation_deg: float = 0.5
    prior_shift_mm: float = 20.0
    prior_focal_pct: float = 2.0
    robust_scale_px: float = 3.0
    outlier_sigmas: float = 4.0
    min_outlier_px: float = 5.0
    rounds: int = 3


@dataclass(frozen=True)
class PeopleBundleReport:
    """How the refinement went.

    Attributes:
        trials: trials used; frames: frames used in all; keypoints: keypoints used (inliers, last round);
        outliers: keypoints rejected; median_before_px / median_after_px: median reprojection error of the
            inliers against points triangulated with the prior rig / after the adjustment, px (per camera
            in ``per_camera_*``); comparison: the refined rig against the prior (per camera centre mm,
            rotation deg, focal %); solve_time_s: s.
    """

    trials: int
    frames: int
    keypoints: int
    outliers: int
    median_before_px: float
    median_after_px: float
    per_camera_before_px: dict[str, float]
    per_camera_after_px: dict[str, float]
    comparison: RigComparison
    solve_time_s: float

    def to_dict(self) -> dict:
        cams = {c.name: {"centre_mm": c.centre_mm, "rotation_deg": c.rotation_deg, "focal_pct": c.focal_pct}
                for c in self.comparison.cameras}
        return {"trials": self.trials, "frames": self.frames, "keypoints": self.keypoints, "outliers": self.outliers,
                "median_before_px": self.median_before_px, "median_after_px": self.median_after_px,
                "per_camera_before_px": self.per_camera_before_px, "per_camera_after_px": self.per_camera_after_px,
                "change_from_prior": cams, "solve_time_s": self.solve_time_s}


@dataclass(frozen=True, eq=False)
class PeopleBundleResult:
    """The refined rig (same cameras, intrinsics other than focal length as given) and the report."""

    rig: Rig
    report: PeopleBundleReport


@dataclass(frozen=True, eq=False)
class _Observations:
    cam: np.ndarray  # (K,) camera index
    point: np.ndarray  # (K,) point index
    uv_px: np.ndarray  # (K, 2)
    points_mm: np.ndarray  # (N, 3) starting points
    frames: int


def _observations(trials: Sequence[MultiViewKeypoints], rig: Rig, config: PeopleBundleConfig) -> _Observations:
    cams, pts, uvs, starts, frames = [], [], [], [], 0
    for det in trials:
        order = rig.index_of(det.camera_names)  # ValueError naming cameras not in the calibration
        c, t, _, _ = det.shape
        sel = np.arange(0, t, max(1, int(np.ceil(t / config.max_frames))))
        part = det.frames(sel)
        start = robust_triangulate(part, rig.subset(det.camera_names), gamma=config.min_confidence).points_mm
        seen = part.confident(config.min_confidence)[:, :, 0]  # (C, T', J)
        usable = (seen.sum(0) >= config.min_views) & np.isfinite(start).all(-1)
        index = np.full(usable.shape, -1)
        index[usable] = np.arange(usable.sum()) + sum(len(s) for s in starts)
        obs = seen & usable[None]
        ci, ti, ji = np.nonzero(obs)
        cams.append(np.asarray(order)[ci])
        pts.append(index[ti, ji])
        uvs.append(part.one_person[ci, ti, ji, :2])
        starts.append(start[usable])
        frames += len(sel)
    if not starts or not sum(len(s) for s in starts):
        raise ValueError(f"refinement from people: no keypoint seen confidently (> {config.min_confidence}) by "
                         f"{config.min_views} cameras in {len(trials)} trial(s)")
    return _Observations(np.concatenate(cams), np.concatenate(pts), np.concatenate(uvs), np.concatenate(starts), frames)


class _Model:
    """Parameter vector: [camera blocks (C x n_cam) | points (N x 3)]; camera block: turn (3, rad),
    centre shift (3, mm), [log focal scale]."""

    def __init__(self, rig: Rig, obs: _Observations, config: PeopleBundleConfig):
        self.rig, self.obs, self.config = rig, obs, config
        self.n_cam = 7 if config.refine_focal else 6
        self.c = len(rig)
        self.r0 = np.stack([cam.rotation for cam in rig])
        self.c0 = np.stack([cam.center_mm for cam in rig])
        self.k = np.stack([cam.matrix_px for cam in rig])
        self.prior_sd = np.r_[np.full(3, np.radians(config.prior_rotation_deg)), np.full(3, config.prior_shift_mm),
                              [config.prior_focal_pct / 100.0] if config.refine_focal else []]

    def split(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return x[: self.c * self.n_cam].reshape(self.c, self.n_cam), x[self.c * self.n_cam :].reshape(-1, 3)

    def project(self, x: np.ndarray, rows: np.ndarray) -> np.ndarray:
        cam_p, pts = self.split(x)
        ci = self.obs.cam[rows]
        rot = rodrigues_batch(cam_p[:, :3]) @ self.r0  # (C, 3, 3)
        centre = self.c0 + cam_p[:, 3:6]
        pc = np.einsum("kij,kj->ki", rot[ci], pts[self.obs.point[rows]] - centre[ci])
        xy = pc[:, :2] / pc[:, 2:3]
        out = np.empty_like(xy)
        focal = np.exp(cam_p[:, 6]) if self.config.refine_focal else np.ones(self.c)
        for c in np.unique(ci):
            m = ci == c
            cam = self.rig[int(c)]
            out[m] = cam.distort_normalized(xy[m]) @ (self.k[c, :2, :2] * focal[c]).T + self.k[c, :2, 2]
        return out

    def residual(self, x: np.ndarray, rows: np.ndarray) -> np.ndarray:
        data = (self.project(x, rows) - self.obs.uv_px[rows]).ravel()
        prior = (self.split(x)[0] / self.prior_sd).ravel() * self.config.robust_scale_px
        return np.concatenate([data, prior])

    def sparsity(self, rows: np.ndarray, size: int) -> coo_matrix:
        """Which residual rows depend on which parameters: a keypoint's two rows on its camera's block and
        its point; a camera's prior rows on its own block."""
        k = len(rows)
        cam_cols = self.obs.cam[rows][:, None] * self.n_cam + np.arange(self.n_cam)  # (k, n_cam)
        pt_cols = self.c * self.n_cam + 3 * self.obs.point[rows][:, None] + np.arange(3)  # (k, 3)
        cols = np.concatenate([cam_cols, pt_cols], 1)  # (k, n_cam + 3)
        data_rows = np.stack([2 * np.arange(k), 2 * np.arange(k) + 1], 1)[:, :, None]  # (k, 2, 1)
        r = np.broadcast_to(data_rows, (k, 2, cols.shape[1])).ravel()
        c = np.broadcast_to(cols[:, None, :], (k, 2, cols.shape[1])).ravel()
        prior = np.arange(self.c * self.n_cam)
        r, c = np.r_[r, 2 * k + prior], np.r_[c, prior]
        return coo_matrix((np.ones(len(r), dtype=np.int8), (r, c)), shape=(2 * k + len(prior), size))

    def rig_at(self, x: np.ndarray) -> Rig:
        cam_p, _ = self.split(x)
        cams = []
        for c, cam in enumerate(self.rig):
            if not cam_p[c].any():  # not adjusted: the calibration exactly, not a round trip through R
                cams.append(cam)
                continue
            rot = rodrigues_batch(cam_p[c, :3]) @ self.r0[c]
            centre = self.c0[c] + cam_p[c, 3:6]
            k = cam.matrix_px.copy()
            if self.config.refine_focal:
                k[:2, :2] *= np.exp(cam_p[c, 6])
            cams.append(cam.replace(rvec=rvec_of(rot), tvec_mm=-rot @ centre, matrix_px=k))
        return Rig(tuple(cams))


def _per_camera(model: _Model, err_px: np.ndarray, rows: np.ndarray) -> dict[str, float]:
    ci = model.obs.cam[rows]
    return {cam.name: float(np.median(err_px[ci == c])) if np.any(ci == c) else float("nan")
            for c, cam in enumerate(model.rig)}


def _first_inliers(err_px: np.ndarray, cam: np.ndarray, num_cameras: int, config: PeopleBundleConfig) -> np.ndarray:
    """Keypoints kept for the first round: judged against their own camera's median error, so a camera
    that moved far (every keypoint of it off by tens of px) keeps its keypoints and can be pulled back."""
    keep = np.zeros(len(err_px), dtype=bool)
    for c in range(num_cameras):
        mine = cam == c
        if mine.any():
            limit = max(config.outlier_sigmas * np.median(err_px[mine]) / RAYLEIGH_MEDIAN, config.min_outlier_px)
            keep[mine] = err_px[mine] <= limit
    return keep


def _with_fixed(residual, x: np.ndarray, free: np.ndarray):
    """``residual`` of the free parameters alone, the others kept at their values in ``x``."""

    def fun(x_free: np.ndarray, rows: np.ndarray) -> np.ndarray:
        full = x.copy()
        full[free] = x_free
        return residual(full, rows)

    return fun


def refine_rig_from_people(trials: Sequence[MultiViewKeypoints], prior: Rig, *, moved: Sequence[str] | None = None,
                           config: PeopleBundleConfig = PeopleBundleConfig()) -> PeopleBundleResult:
    """Refine ``prior`` (a board calibration) from the people seen in ``trials`` (each (C, T, J, 3) px).

    ``moved``: the cameras known to have moved since ``prior`` (the rig check's): only they are adjusted;
    every other camera keeps its calibration exactly. A prior (robust or Gaussian) of a board calibration's
    own accuracy cannot hold a camera against thousands of keypoints, so a detector's own bias would pull
    cameras that never moved (on Pose2Sim's real demo about 1 deg), and the moved camera with them. None
    (default): every camera is adjusted under its robust prior, any may leave it.
    Returns the refined rig and a report comparing it with ``prior``. ValueError when no keypoint is seen
    by enough cameras, naming the threshold, or when a camera of ``moved`` is not in ``prior``.
    """
    t0 = time.perf_counter()
    if not trials:
        raise ValueError("refinement from people: no trial given")
    unknown = sorted(set(moved or ()) - set(prior.names))
    if unknown:
        raise ValueError(f"refinement from people: moved camera(s) {unknown} not in the calibration ({list(prior.names)})")
    obs = _observations(trials, prior, config)
    model = _Model(prior, obs, config)
    x = np.r_[np.zeros(model.c * model.n_cam), obs.points_mm.ravel()]
    all_rows = np.arange(len(obs.cam))
    err0 = np.linalg.norm(model.project(x, all_rows) - obs.uv_px, axis=-1)
    inlier = _first_inliers(err0, obs.cam, model.c, config)
    free = np.ones(len(x), dtype=bool)
    free[: model.c * model.n_cam] = np.repeat([moved is None or cam.name in moved for cam in prior], model.n_cam)
    for rnd in range(config.rounds):
        rows = np.flatnonzero(inlier)
        fit = least_squares(_with_fixed(model.residual, x, free), x[free], args=(rows,),
                            jac_sparsity=model.sparsity(rows, len(x)).tocsc()[:, free], loss="soft_l1",
                            f_scale=config.robust_scale_px, method="trf", tr_solver="lsmr", x_scale="jac",
                            max_nfev=50)
        x = x.copy()
        x[free] = fit.x
        err = np.linalg.norm(model.project(x, all_rows) - obs.uv_px, axis=-1)
        limit = max(config.outlier_sigmas * np.median(err[inlier]) / RAYLEIGH_MEDIAN, config.min_outlier_px)
        keep = err <= limit
        log.info("people bundle round %d: median %.2f px, %d outliers", rnd + 1, np.median(err[keep]), (~keep).sum())
        if np.array_equal(keep, inlier):
            break
        inlier = keep
    rows = np.flatnonzero(inlier)
    rig = model.rig_at(x)
    report = PeopleBundleReport(
        trials=len(trials), frames=obs.frames, keypoints=int(inlier.sum()), outliers=int((~inlier).sum()),
        median_before_px=float(np.median(err0[rows])), median_after_px=float(np.median(err[rows])),
        per_camera_before_px=_per_camera(model, err0[rows], rows), per_camera_after_px=_per_camera(model, err[rows], rows),
        comparison=compare_rigs(prior, rig), solve_time_s=time.perf_counter() - t0,
    )
    return PeopleBundleResult(rig, report)
