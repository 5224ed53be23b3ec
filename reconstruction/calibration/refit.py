"""How well a given calibration explains board corners: the rig held as given (intrinsics and poses), the
board pose of every frame set fitted to all the cameras that saw it (the bundle adjustment's robust loss
and outlier rounds, nothing else free), then each camera's reprojection error computed as the
calibration report computes it. Used to measure another tool's calibration on our corners."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from gaitcap.reconstruction.calibration.bundle import (
    BundleConfig,
    BundleProblem,
    BundleResult,
    BundleState,
    bundle_adjust,
)
from gaitcap.reconstruction.calibration.geometry import BoardObservations, rotation_angle_deg
from gaitcap.reconstruction.calibration.intrinsics import Intrinsics
from gaitcap.reconstruction.calibration.report import error_stats
from gaitcap.reconstruction.calibration.views import view_poses
from gaitcap.reconstruction.camera import Rig


@dataclass(frozen=True)
class RigFit:
    """Per camera (in ``cameras`` order): views used, reprojection RMS and p95 over the inlier corners (px,
    as :class:`CameraQuality`), RMS over all its corners, outliers included (px, the refusal's figure),
    and corners rejected as outliers."""

    cameras: tuple[str, ...]
    views: tuple[int, ...]
    rms_px: tuple[float, ...]
    p95_px: tuple[float, ...]
    rms_all_px: tuple[float, ...]
    outliers: tuple[int, ...]


def _view_symmetries(obs: BoardObservations, rig: Rig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(C, F) symmetry of each usable view (-1: none) and each frame's first board -> world pose from the
    given rig; a camera's symmetry is the one whose world pose agrees best with that first pose."""
    cams = [rig[n] for n in obs.camera_names]
    poses = view_poses(obs, [Intrinsics(c.matrix_px, c.dist, float("nan")) for c in cams])
    n_cams, n_frames = obs.shape[0], obs.shape[1]
    sym = np.full((n_cams, n_frames), -1)
    rot, tvec = np.full((n_frames, 3, 3), np.nan), np.full((n_frames, 3), np.nan)
    for f in range(n_frames):
        for c, cam in enumerate(cams):
            world_r = cam.rotation.T @ poses.rotation[c, f]  # board -> world, per symmetry
            valid = np.flatnonzero(poses.valid[c, f])
            if not len(valid):
                continue
            if np.isnan(rot[f, 0, 0]):
                sym[c, f] = valid[0]
                rot[f] = world_r[valid[0]]
                tvec[f] = cam.rotation.T @ (poses.tvec_mm[c, f, valid[0]] - cam.tvec_mm)
            else:
                sym[c, f] = valid[np.argmin([rotation_angle_deg(world_r[s], rot[f]) for s in valid])]
    return sym, rot, tvec


@dataclass(frozen=True, eq=False)
class BoardFit:
    """The board poses fitted to a rig held fixed: the flattened corners (``problem``, frames compacted),
    the adjustment's result (residuals px, inliers) and ``frames`` (F',): the given frame of each."""

    problem: BundleProblem
    result: BundleResult
    frames: np.ndarray

    def ordered_inliers_px(self) -> np.ndarray:
        """(C, F', N, 2) the inlier corners in the board's true order (NaN elsewhere)."""
        p, inl = self.problem, self.result.inlier
        out = np.full((p.num_cameras, p.num_frames, len(p.object_points_mm), 2), np.nan)
        out[p.cam[inl], p.frame[inl], p.corner[inl]] = p.uv_px[inl]
        return out


def board_fit(obs: BoardObservations, rig: Rig, *, config: BundleConfig | None = None) -> BoardFit:
    """Every frame set's board pose fitted to ``rig`` held fixed (intrinsics and poses; every camera of
    ``obs`` must be in it, KeyError naming it otherwise), with the bundle adjustment's robust loss and
    outlier rounds; views no pose of the rig's intrinsics fits (PnP) are not used."""
    sym, rot, tvec = _view_symmetries(obs, rig)
    syms = np.asarray(obs.board.symmetries)
    frames = np.flatnonzero((sym >= 0).any(0))
    compact = np.full(obs.shape[1], -1)
    compact[frames] = np.arange(len(frames))
    rows = []
    for c, f in zip(*np.nonzero(sym >= 0), strict=True):
        seen = np.all(np.isfinite(obs.corners_px[c, f]), -1)
        ids = syms[sym[c, f]][seen]
        rows.append((np.full(len(ids), c), np.full(len(ids), compact[f]), ids, obs.corners_px[c, f][seen]))
    if not rows:
        raise ValueError(f"no board view fits a pose with the calibration of cameras {list(obs.camera_names)}")
    cam, frame, corner, uv = (np.concatenate(parts) for parts in zip(*rows, strict=True))
    prob = BundleProblem(cam, frame, corner, uv, obs.board.object_points_mm, obs.shape[0], len(frames), 0, ())
    cams = [rig[n] for n in obs.camera_names]
    state = BundleState(np.stack([c.matrix_px for c in cams]), np.stack([c.dist for c in cams]),
                        np.stack([c.rotation for c in cams]), np.stack([c.tvec_mm for c in cams]),
                        rot[frames], tvec[frames])
    res = bundle_adjust(prob, state, replace(config or BundleConfig(), refine_intrinsics=False, refine_cameras=False))
    return BoardFit(prob, res, frames)


def fit_board_to_rig(obs: BoardObservations, rig: Rig, *, config: BundleConfig | None = None) -> RigFit:
    """The board poses fitted to ``rig`` held fixed (every camera of ``obs`` must be in it, KeyError
    naming it otherwise) and each camera's reprojection figures on these corners."""
    fit = board_fit(obs, rig, config=config)
    prob, res = fit.problem, fit.result
    err = np.linalg.norm(res.residual_px, axis=-1)
    out = {"views": [], "rms_px": [], "p95_px": [], "rms_all_px": [], "outliers": []}
    for c in range(obs.shape[0]):
        mine = prob.cam == c
        _, p95, rms = error_stats(err[mine & res.inlier])
        out["views"].append(len(np.unique(prob.frame[mine])))
        out["rms_px"].append(rms)
        out["p95_px"].append(p95)
        out["rms_all_px"].append(float(np.sqrt(np.mean(err[mine] ** 2))) if mine.any() else float("nan"))
        out["outliers"].append(int((mine & ~res.inlier).sum()))
    return RigFit(tuple(obs.camera_names), **{k: tuple(v) for k, v in out.items()})
