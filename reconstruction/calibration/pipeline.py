"""Calibration from board observations: intrinsics -> single-view poses -> camera graph -> bundle
adjustment -> world frame from the floor board -> Rig + quality report."""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, replace

import numpy as np
from gaitcap.reconstruction.calibration.board_check import check_board, size_problem
from gaitcap.reconstruction.calibration.bundle import (
    BundleConfig,
    BundleProblem,
    BundleResult,
    BundleState,
    bundle_adjust,
    outlier_threshold_px,
)
from gaitcap.reconstruction.calibration.geometry import BoardObservations
from gaitcap.reconstruction.calibration.graph import InitialPoses, initial_poses
from gaitcap.reconstruction.calibration.intrinsics import Intrinsics, IntrinsicsConfig, estimate_intrinsics
from gaitcap.reconstruction.calibration.motion import (
    MotionConfig,
    corner_velocities,
    motion_report,
    offset_errors,
    speed_weights,
)
from gaitcap.reconstruction.calibration.report import (
    CameraQuality,
    QualityReport,
    QualityThresholds,
    coverage,
    error_stats,
    measured_square_mm,
)
from gaitcap.reconstruction.calibration.still import merge_still_frames
from gaitcap.reconstruction.calibration.views import view_poses
from gaitcap.reconstruction.calibration.whole_views import LEFT_OUT_REASON, WholeViews, disagreeing_views
from gaitcap.reconstruction.calibration.world import (
    WorldFrameConfig,
    floor_plane,
    floor_pose,
    to_world,
    world_from_floor,
)
from gaitcap.reconstruction.camera import Camera, Rig, matrix_to_rodrigues

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class CalibrationConfig:
    """Everything that steers a calibration (all parts have sensible defaults).

    known_intrinsics: {camera: (K (3, 3) px, dist (5,))} from an earlier calibration (e.g. a separate
    intrinsics session, as caliscope and Pose2Sim do): held fixed, only the poses are estimated. Every
    camera must be in it when given.
    leave_out_disagreeing_views: views disagreeing with the other cameras as a whole are left out and
    counted per camera (:mod:`gaitcap.reconstruction.calibration.whole_views`); False: every view is kept
    and judged.
    camera_intrinsics: {camera: IntrinsicsConfig} for cameras whose lens model or principal point differ
    from ``intrinsics`` (e.g. chosen per camera by held-out error:
    :mod:`gaitcap.reconstruction.calibration.model_choice`).
    share_focal: identical cameras (the same image size, focal lengths from their own views within
    ``share_focal_within`` of each other) share a focal length prior in the bundle adjustment: each one's
    fx, fy pulled towards the group's mean with a standard deviation of ``focal_prior_rel`` of it.
    motion: the board's motion modelled after the first bundle adjustment (each camera's time offset,
    views weighted by the board's speed: :mod:`gaitcap.reconstruction.calibration.motion`), then the
    adjustment run again; None (the default): not modelled (on caliscope's 4 webcams it left the held-out
    error where it was: docs/calibration.md).
    """

    intrinsics: IntrinsicsConfig = field(default_factory=IntrinsicsConfig)
    bundle: BundleConfig = field(default_factory=BundleConfig)
    world: WorldFrameConfig = field(default_factory=WorldFrameConfig)
    thresholds: QualityThresholds = field(default_factory=QualityThresholds)
    known_intrinsics: Mapping[str, tuple[np.ndarray, np.ndarray]] | None = None
    leave_out_disagreeing_views: bool = True
    camera_intrinsics: Mapping[str, IntrinsicsConfig] | None = None
    share_focal: bool = False
    share_focal_within: float = 0.05
    focal_prior_rel: float = 0.01
    motion: MotionConfig | None = None

    def intrinsics_of(self, camera: str) -> IntrinsicsConfig:
        """The intrinsics config of one camera (``camera_intrinsics`` where it names it)."""
        return (self.camera_intrinsics or {}).get(camera, self.intrinsics)


@dataclass(frozen=True, eq=False)
class CalibrationResult:
    """The calibrated rig (world frame: floor board, mm) and its quality report.

    board_rotation (F, 3, 3) / board_tvec_mm (F, 3): recovered board -> world poses (NaN if unused).
    """

    rig: Rig
    report: QualityReport
    board_rotation: np.ndarray
    board_tvec_mm: np.ndarray


def _check_cameras(obs: BoardObservations, config: IntrinsicsConfig) -> None:
    counts = obs.views().sum(1)
    few = [f"{n!r} ({k} views)" for n, k in zip(obs.camera_names, counts, strict=True) if k < config.min_views]
    if few:
        raise ValueError(
            f"cameras {', '.join(few)} saw the board too rarely (need at least {config.min_views} views "
            f"with {obs.board.min_corners}+ corners of {obs.board.name}); record again moving the board "
            "through every camera's whole view, closer and slower"
        )


def _problem(obs: BoardObservations, init: InitialPoses, models: list[tuple[int, ...]], intr: list[Intrinsics],
             groups: np.ndarray | None = None, focal_prior_rel: float = 0.01):
    """Flatten the usable views into a BundleProblem (frames compacted); returns it, the frame map and
    each row's flat index into the observations' (C, F, N) corners (detector order).
    ``models``: each camera's free distortion terms (indices into k1, k2, p1, p2, k3); ``groups``: each
    camera's focal prior group (None: no prior)."""
    free_dist = tuple(sorted(set().union(*models)))
    syms = np.asarray(obs.board.symmetries)
    c_idx, f_idx = np.nonzero(init.symmetry >= 0)
    frames = np.unique(f_idx)
    compact = np.full(obs.shape[1], -1)
    compact[frames] = np.arange(len(frames))
    cams, frs, corners, uv, src = [], [], [], [], []
    for c, f in zip(c_idx, f_idx, strict=True):
        seen = np.all(np.isfinite(obs.corners_px[c, f]), -1)
        ids = syms[init.symmetry[c, f]][seen]
        cams.append(np.full(len(ids), c))
        frs.append(np.full(len(ids), compact[f]))
        corners.append(ids)
        uv.append(obs.corners_px[c, f][seen])
        src.append(np.ravel_multi_index((c, f, np.flatnonzero(seen)), obs.shape))
    prob = BundleProblem(
        np.concatenate(cams), np.concatenate(frs), np.concatenate(corners), np.concatenate(uv),
        obs.board.object_points_mm, obs.shape[0], len(frames), init.root, free_dist,
        np.array([i.principal_point_held for i in intr]), _held_distortion(intr, models), groups,
        focal_prior_rel,
    )
    return prob, frames, np.concatenate(src)


def focal_groups(sizes_px, focal_px: np.ndarray, within: float) -> np.ndarray:
    """(C,) group of each camera (-1: alone): cameras of the same image size whose focal lengths (C,) px,
    in order, lie within ``within`` (relative) of the next (one model's focal lengths estimated from
    different views spread a little)."""
    group = np.full(len(focal_px), -1)
    n = 0
    for size in sorted(set(sizes_px)):
        cams = [c for c in np.argsort(focal_px) if tuple(sizes_px[c]) == size]
        start = 0
        for i in range(1, len(cams) + 1):
            if i == len(cams) or focal_px[cams[i]] > (1 + within) * focal_px[cams[i - 1]]:
                if i - start > 1:
                    group[cams[start:i]] = n
                    n += 1
                start = i
    return group


def _held_distortion(intr: list[Intrinsics], models: list[tuple[int, ...]]) -> np.ndarray:
    """(C, 5) bool: the distortion terms each camera holds at 0 although the problem frees them (its own
    model frees fewer, or its views could not determine them)."""
    held = np.zeros((len(intr), 5), dtype=bool)
    for c, (i, free) in enumerate(zip(intr, models, strict=True)):
        held[c, list(i.distortion_held)] = True
        held[c, [t for t in range(5) if t not in free]] = True
    return held


def _notes(n_left: int, n_undecidable: int) -> tuple[str, ...]:
    notes = (f"{n_left} view{'s' * (n_left != 1)} left out: {LEFT_OUT_REASON}",) if n_left else ()
    if n_undecidable:
        notes += (f"{n_undecidable} view{'s' * (n_undecidable != 1)} disagreeing as a whole kept: too few other "
                  "cameras agreeing in their frame sets to tell which view was wrong",)
    return notes


def _shared_note(obs, prob, c: int) -> tuple[str, ...]:
    """The note of a camera whose focal length shared a prior with identical cameras (else none)."""
    if prob.focal_group is None or prob.focal_group[c] < 0:
        return ()
    others = [n for k, n in enumerate(obs.camera_names) if prob.focal_group[k] == prob.focal_group[c] and k != c]
    return (f"focal length prior shared with {', '.join(others)} (identical cameras: the same image size, focal "
            f"lengths within a few per cent; standard deviation {100 * prob.focal_prior_rel:g} %)",)


def _camera_quality(obs, prob, res: BundleResult, c: int, thresholds: QualityThresholds, all_rms: float,
                    others_rms: float, intr: Intrinsics | None, whole: WholeViews, found: int) -> CameraQuality:
    """One camera's figures and problems, on its views kept (``whole``: the views left out as disagreeing
    as a whole); ``intr``: its intrinsics as estimated from its views (None: given), where coverage matters
    unless what the views could not determine was held; ``found``: its views as the detector gave them
    (before pairing or readout removed any)."""
    mine = (prob.cam == c) & ~whole.left_out
    n_left = int(whole.views_left_out[c])
    held = intr.held if intr is not None else ()
    notes = held + _shared_note(obs, prob, c) + _notes(n_left, int(whole.views_undecidable[c]))
    err = np.linalg.norm(res.residual_px[mine & res.inlier], axis=-1)
    mean, p95, rms = error_stats(err)
    cov = coverage(prob.uv_px[mine & res.inlier], obs.image_sizes_px[c], thresholds.grid)
    problems = []
    if not p95 <= thresholds.max_p95_px:
        problems.append(f"reprojection p95 {p95:.2f} px > {thresholds.max_p95_px} px")
    if intr is not None and not intr.held and cov < thresholds.min_coverage:
        problems.append(f"board covered {100 * cov:.0f} % of the image (< {100 * thresholds.min_coverage:.0f} %)")
    if _over_rms(all_rms, others_rms, thresholds):
        problems.append(f"reprojection RMS over all its corners {all_rms:.2f} px is {all_rms / others_rms:.1f} x "
                        f"the other cameras' median ({others_rms:.2f} px)")
    n_views = len(np.unique(prob.frame[mine]))
    if n_views < thresholds.min_views_kept_fraction * found:
        given = int(obs.views()[c].sum())  # views handed to the calibration (still runs merged)
        problems.append(f"judged on {n_views} of its {found} views found (< {100 * thresholds.min_views_kept_fraction:.0f} "
                        f"%): {found - given} removed before calibration (smeared during the readout), {n_left} left "
                        f"out as disagreeing with the other cameras, {given - n_left - n_views} not placed in the rig")
    return CameraQuality(
        obs.camera_names[c], n_views, int((mine & res.inlier).sum()), int((mine & ~res.inlier).sum()),
        mean, p95, rms, cov, not problems, tuple(problems), median_px=float(np.median(err)) if err.size else
        float("nan"), views_found=found, views_kept_fraction=n_views / found if found else 0.0,
        views_left_out=n_left, views_undecidable=int(whole.views_undecidable[c]), notes=notes, held=held,
        focal_rel_std=intr.focal_rel_std if intr is not None else float("nan"),
    )


def _over_rms(all_rms: float | np.ndarray, others_rms: float | np.ndarray, thresholds: QualityThresholds):
    """The RMS rule: a camera's RMS over all its corners (px) too far above the other cameras' median."""
    return (all_rms > thresholds.max_rms_ratio * others_rms) & (all_rms > thresholds.rms_floor_px)


def _others_median(rms: np.ndarray) -> np.ndarray:
    """(C,) the median of the other cameras' RMS (px; its own when alone)."""
    n = len(rms)
    return np.array([float(np.nanmedian(np.delete(rms, c))) if n > 1 else float(rms[c]) for c in range(n)])


def _whole_views(obs, config, prob, res: BundleResult, found: np.ndarray) -> WholeViews:
    """The views left out as disagreeing as a whole (none when the config turns that off)."""
    none = np.zeros(obs.shape[0], dtype=int)
    if not config.leave_out_disagreeing_views:
        return WholeViews(np.zeros(len(prob.cam), dtype=bool), none, none)
    rms = _rms_per_camera(prob, res, obs.shape[0], np.zeros(len(prob.cam), dtype=bool))
    refused = _over_rms(rms, _others_median(rms), config.thresholds)
    return disagreeing_views(prob, res, config.bundle, views_found=found, refused=refused)


def _rms_per_camera(prob, res: BundleResult, n_cams: int, left_out: np.ndarray) -> np.ndarray:
    """Each camera's reprojection RMS over ALL the corners of its views kept, outliers included (px): a
    noisy camera loses many corners to outlier rejection, which would hide it from an inlier RMS."""
    out = np.full(n_cams, np.nan)
    for c in range(n_cams):
        err = res.residual_px[(prob.cam == c) & ~left_out]
        if len(err):
            out[c] = float(np.sqrt(np.mean(np.sum(err**2, -1))))
    return out


def _outlier_corners(obs, prob, res: BundleResult, given: np.ndarray, left_out: np.ndarray) -> dict:
    """{camera: [{"frame", "corners", "max_px"}]}: the corners the bundle adjustment dropped as outliers
    (views left out as a whole not counted), per camera and given frame (``given``: (F',) the given frame
    of each problem frame)."""
    err = np.linalg.norm(res.residual_px, axis=-1)
    out: dict[str, list[dict]] = {}
    bad = ~res.inlier & ~left_out
    for c, name in enumerate(obs.camera_names):
        mine = bad & (prob.cam == c)
        views = [{"frame": int(given[f]), "corners": prob.corner[mine & (prob.frame == f)].tolist(),
                  "max_px": float(err[mine & (prob.frame == f)].max())} for f in np.unique(prob.frame[mine])]
        if views:
            out[name] = views
    return out


def _board_check(obs, res: BundleResult, ordered: np.ndarray, extr: np.ndarray) -> tuple[dict, tuple[str, ...]]:
    """The board measured in 3D with the fitted rig (inlier corners) and what it found wrong."""
    check = check_board(ordered, res.state.matrix_px, res.state.dist, extr, obs.board, obs.camera_names)
    problem = size_problem(check)
    return {**asdict(check), "square_residual_pct": check.square_residual_pct}, (problem,) if problem else ()


def _report(obs, config, prob, frames, res, world, cams_r, cams_t, whole: WholeViews, found: np.ndarray,
            intr: list[Intrinsics], given: np.ndarray) -> QualityReport:
    left_out = whole.left_out
    rms = _rms_per_camera(prob, res, obs.shape[0], left_out)
    others = _others_median(rms)
    estimated = intr if config.known_intrinsics is None else [None] * obs.shape[0]
    per_cam = tuple(_camera_quality(obs, prob, res, c, config.thresholds, rms[c], others[c], estimated[c], whole,
                                    int(found[c])) for c in range(obs.shape[0]))
    mean, p95, rms = error_stats(np.linalg.norm(res.residual_px[res.inlier], axis=-1))
    ordered = np.full((obs.shape[0], len(frames), obs.board.num_corners, 2), np.nan)
    inl = res.inlier
    ordered[prob.cam[inl], prob.frame[inl], prob.corner[inl]] = prob.uv_px[inl]
    extr = np.concatenate([cams_r, cams_t[:, :, None]], axis=2)
    square = measured_square_mm(ordered, res.state.matrix_px, res.state.dist, extr, obs.board.neighbours)
    board, board_problems = _board_check(obs, res, ordered, extr)
    return QualityReport(
        board=obs.board.name, distortion=_models(obs, config), cameras=per_cam,
        failed_cameras=tuple(q.name for q in per_cam if not q.ok), n_frames=len(frames),
        n_corners=int(inl.sum()), n_outliers=int((~inl & ~left_out).sum()), reprojection_mean_px=mean,
        reprojection_p95_px=p95, reprojection_rms_px=rms, square_mm=obs.board.square_mm,
        square_measured_mm=square, square_residual_pct=100 * (square / obs.board.square_mm - 1),
        floor_frames=world.floor_frames, world_flipped=world.flipped, bundle_rounds=res.rounds,
        solve_time_s=res.solve_time_s, board_check=board, board_problems=board_problems,
        outlier_threshold_px=outlier_threshold_px(np.linalg.norm(res.residual_px[inl], axis=-1), config.bundle),
        outlier_corners=_outlier_corners(obs, prob, res, given[frames], left_out),
    )


def _models(obs: BoardObservations, config: CalibrationConfig) -> str:
    """The distortion model, or each camera's where they differ (e.g. ``k1 (cam_0), k1k2 (cam_1)``)."""
    models = [config.intrinsics_of(n).distortion.value for n in obs.camera_names]
    if len(set(models)) == 1:
        return models[0]
    return ", ".join(f"{m} ({n})" for n, m in zip(obs.camera_names, models, strict=True))


def _initial_state(intr: list[Intrinsics], init: InitialPoses, frames: np.ndarray) -> BundleState:
    return BundleState(
        np.stack([i.matrix_px for i in intr]), np.stack([i.dist for i in intr]), init.cam_rotation,
        init.cam_tvec_mm, init.frame_rotation[frames], init.frame_tvec_mm[frames],
    )


def _intrinsics(obs: BoardObservations, config: CalibrationConfig) -> list[Intrinsics]:
    """Each camera's intrinsics: the known ones when given (ValueError naming a camera without), else
    estimated from its own board views."""
    if config.known_intrinsics is None:
        return [estimate_intrinsics(obs, c, config.intrinsics_of(n)) for c, n in enumerate(obs.camera_names)]
    missing = [n for n in obs.camera_names if n not in config.known_intrinsics]
    if missing:
        raise ValueError(f"known intrinsics: none given for cameras {missing} "
                         f"(given: {sorted(config.known_intrinsics)})")
    out = []
    for name in obs.camera_names:
        k, dist = (np.asarray(a, dtype=np.float64) for a in config.known_intrinsics[name])
        if k.shape != (3, 3) or dist.size > 5:
            raise ValueError(f"known intrinsics of camera {name!r}: need K (3, 3) and up to 5 distortion terms")
        out.append(Intrinsics(k, np.pad(dist.ravel(), (0, 5 - dist.size)), float("nan")))
    return out


def _with_motion(obs, prob: BundleProblem, res: BundleResult, src: np.ndarray, config: CalibrationConfig):
    """The board's motion modelled from the first fit (views weighted by speed; each camera's time offset
    adjusted where every camera has enough corners with a velocity) and the adjustment run again:
    (problem, result, report)."""
    mc = config.motion
    vel = corner_velocities(obs, mc.max_gap_s).reshape(-1, 2)[src]
    weights = speed_weights(cam=prob.cam, frame=prob.frame, residual_px=res.residual_px, inlier=res.inlier,
                            velocity_px_s=vel, config=mc)
    known = np.isfinite(vel).all(-1)
    counts = np.bincount(prob.cam[known], minlength=prob.num_cameras)
    few = [f"{n} ({k})" for n, k in zip(obs.camera_names, counts, strict=True) if k < mc.min_corners]
    timed = mc.offsets and not few and config.bundle.refine_cameras
    why_not = "" if timed or not mc.offsets or not counts.any() else (
        f"time offsets not adjusted: cameras {', '.join(few)} have fewer than {mc.min_corners} corners with a "
        "velocity" if few else "time offsets not adjusted: the camera poses are held")
    if not timed and np.isnan(weights.smear_s):
        return prob, res, motion_report(obs.camera_names, prob.root, None, np.zeros(0), weights, mc, why_not)
    v = np.where(known[:, None], vel, 0.0)
    prob = replace(prob, weight=weights.weight, velocity_px_s=v if timed else None)
    start = replace(res.state, time_offset_s=np.zeros(prob.num_cameras) if timed else None)
    res = bundle_adjust(prob, start, config.bundle)
    offsets = res.state.time_offset_s if timed else None
    se = offset_errors(cam=prob.cam, residual_px=res.residual_px, inlier=res.inlier, velocity_px_s=v,
                       weight=weights.weight, n_cams=prob.num_cameras)
    report = motion_report(obs.camera_names, prob.root, offsets, se, weights, mc, why_not)
    for note in report.notes:
        log.info("calibration: %s", note)
    return prob, res, report


def _views_found(obs: BoardObservations, removed: Mapping[str, int] | None) -> np.ndarray:
    """(C,) each camera's views as found: those in ``obs`` plus those removed before (ValueError naming
    a camera not in ``obs`` or a negative count)."""
    removed = dict(removed or {})
    unknown = sorted(set(removed) - set(obs.camera_names))
    if unknown or any(v < 0 for v in removed.values()):
        raise ValueError(f"views removed before calibration: cameras {unknown} are not in the observations "
                         f"{list(obs.camera_names)}, or a count is negative ({removed})")
    return obs.views().sum(1) + np.array([removed.get(n, 0) for n in obs.camera_names])


def calibrate_from_observations(
    obs: BoardObservations, *, config: CalibrationConfig | None = None, serials: dict[str, str] | None = None,
    views_removed: Mapping[str, int] | None = None,
) -> CalibrationResult:
    """Calibrate every camera in ``obs``; ValueError naming the camera when its data cannot do it.
    ``views_removed``: {camera: views found but removed before calibration (smeared during the readout)},
    counted in its views found (the base of the leave-out cap and of the views-kept refusal)."""
    config = config or CalibrationConfig()
    n_given = obs.shape[1]
    obs, kept = merge_still_frames(obs)
    found = _views_found(obs, views_removed)  # on the merged frames, as the views used are counted
    runs = np.searchsorted(kept, np.arange(n_given), side="right") - 1  # merged frame of each given frame
    _check_cameras(obs, config.intrinsics)
    intr = _intrinsics(obs, config)
    if config.known_intrinsics is not None:
        config = replace(config, bundle=replace(config.bundle, refine_intrinsics=False))
    poses = view_poses(obs, intr)
    no_pose = [n for c, n in enumerate(obs.camera_names) if not poses.valid[c].any()]
    if no_pose:
        raise ValueError(f"cameras {no_pose}: no board view gave a consistent pose; check the board definition")
    init = initial_poses(poses, obs.camera_names)
    groups = (focal_groups(obs.image_sizes_px, np.array([i.matrix_px[0, 0] for i in intr]), config.share_focal_within)
              if config.share_focal and config.known_intrinsics is None else None)
    prob, frames, src = _problem(obs, init, [config.intrinsics_of(n).distortion.free for n in obs.camera_names],
                                 intr, groups, config.focal_prior_rel)
    res = bundle_adjust(prob, _initial_state(intr, init, frames), config.bundle)
    motion = None
    if config.motion is not None:
        prob, res, motion = _with_motion(obs, prob, res, src, config)
    whole = _whole_views(obs, config, prob, res, found)
    if whole.left_out.any():
        res = bundle_adjust(prob, res.state, config.bundle, exclude=whole.left_out)
    used = np.zeros(obs.shape[1], dtype=bool)
    used[frames] = True
    full_r, full_t = np.full((obs.shape[1], 3, 3), np.nan), np.full((obs.shape[1], 3), np.nan)
    full_r[frames], full_t[frames] = res.state.frame_rotation, res.state.frame_tvec_mm
    r_floor, t_floor, _ = floor_pose(full_r, full_t, used, config.world)
    r_floor, t_floor, n_floor = floor_plane(r_floor, t_floor, full_r, full_t, used, obs.board.object_points_mm,
                                            config.world)
    symmetric = np.ptp(obs.board.object_points_mm[:, :2], axis=0) if len(obs.board.symmetries) > 1 else None
    world = world_from_floor(r_floor, t_floor, res.state.cam_rotation, res.state.cam_tvec_mm, floor_frames=n_floor,
                             symmetric_extent_mm=symmetric)
    cams_r, cams_t = to_world(world, res.state.cam_rotation, res.state.cam_tvec_mm)
    serials = serials or {}
    rig = Rig(tuple(
        Camera(name, obs.image_sizes_px[c], res.state.matrix_px[c], res.state.dist[c],
               matrix_to_rodrigues(cams_r[c]), cams_t[c], serials.get(name, ""))
        for c, name in enumerate(obs.camera_names)
    ))
    report = _report(obs, config, prob, frames, res, world, cams_r, cams_t, whole, found, intr, kept)
    if motion is not None:
        report = replace(report, motion=motion.to_dict())
    board_r = np.full((len(runs), 3, 3), np.nan)  # board -> world, for every frame given (still runs share)
    board_t = np.full((len(runs), 3), np.nan)
    board_r[:] = np.einsum("ji,fjk->fik", world.rotation, full_r)[runs]
    board_t[:] = np.einsum("ji,fj->fi", world.rotation, full_t - world.tvec_mm)[runs]
    return CalibrationResult(rig, report, board_r, board_t)
