"""Benchmark: calibration of the synthetic 10-camera room from a board recording.

A board (the paper's 7 x 5 checkerboard of 110 mm squares, or the 5 x 7 ChArUco of 109 mm) lies on the
floor for the first frames, then is carried through the room, shown to each camera up close and held
in view of several cameras at once, sometimes upside down; its corners are seen with Gaussian pixel
noise and reported in a scrambled order (as an orientation-blind detector would). The calibration's
camera centres and rotations are compared with the room's true rig (same world frame: the floor
board), the reprojection RMS with the noise level, and a walking trial triangulated with the recovered
calibration with the one triangulated with the true calibration (robust triangulation, MPJPE).
The board is also laid down at three more floor spots (a better floor plane). A short rendered clip
measures the real detector on images (accuracy vs the projected corners, time). With ``--images N`` the
whole chain runs end to end: N frames of all 10 cameras rendered at full resolution, written as a trial
MCAP, the board detected, the cameras calibrated and compared with the truth (as ``gaitcap
simulate-board`` and ``gaitcap calibrate --compare`` do).

    python bench/calibration.py                      # a table
    python bench/calibration.py --json               # one JSON object on stdout
    python bench/calibration.py --board charuco --frames 900 --noise-px 1.0
    python bench/calibration.py --images 600         # + end to end from images (about 30 min on 2 cores)
    python bench/calibration.py --real-only          # only the real recordings (below), about a minute
                                                     # + caliscope's 11-camera session: about 6 min more
    python bench/calibration.py --real-only --sync-every 20   # that session thinned as in the tests: a minute
    python bench/calibration.py --small-board --sync-every 20 [--json]   # small boards, intrinsics from the clip
    python bench/calibration.py --small-board --sync-every 20 --folds 5 [--choose-intrinsics]   # + held-out
    python bench/calibration.py --small-board --folds 5 --session caliscope-4cam   # one session
    (with caliscope's scripting API installed, pip install -e '.[caliscope]', caliscope's own calibration is
    also fitted on each fold's frame sets and judged on the same held-out ones: the comparison on equal terms)

Real recordings (installed by deploy/bootstrap.sh; skipped when absent): caliscope's 4-webcam session of
a hand-held inverted ChArUco board (its own corner detections, calibrated here with caliscope's
intrinsics and with intrinsics estimated from the clip, compared with caliscope's calibration after a
similarity alignment; and caliscope's own calibration measured on the same corners: its cameras held,
each frame set's board pose fitted, then reprojected), caliscope's real checkerboard frames (how many
views the detector finds, and how fast) and Pose2Sim's demo intrinsics images (found views, and each
camera's focal length against Qualisys's calibration of the same cameras); OpenCV's own samples (a real
stereo pair calibrated from its images and compared with OpenCV's calibration, a real ChArUco photo: see
bench/_real_opencv.py). caliscope's 11-camera 1920x1080 session (10028 views of a 4 x 6 ChArUco board,
whole unless --sync-every) is calibrated the same two ways and compared with caliscope's bundle-adjusted
calibration of it.
"""

from __future__ import annotations

import argparse
import json
import logging
import time
from dataclasses import replace

import numpy as np
from _common import jsonable
from _real_opencv import opencv_lines, opencv_samples
from gaitcap.acquisition.installed import share_path

TARGET_CENTRE_MM = 5.0
TARGET_ROTATION_DEG = 0.2
TARGET_MPJPE_MM = 2.0
REAL_TARGET_RMS_PX = 1.0  # the targets on real webcams, against an established tool's calibration
REAL_TARGET_CENTRE_MM = 15.0
REAL_TARGET_ROTATION_DEG = 1.0
FLOOR_SPOTS_MM = ((1500.0, 1500.0), (-1500.0, 1200.0), (1000.0, -1500.0))  # board laid down again here


def _calibration(board_kind: str, frames: int, floor_frames: int, noise_px: float, seed: int,
                 still_floor: bool = False) -> dict:
    from gaitcap.acquisition.boards.detection import BoardConfig, make_board
    from gaitcap.reconstruction.calibration import calibrate_from_observations
    from gaitcap.reconstruction.calibration.geometry import rotation_angle_deg
    from gaitcap.reconstruction.triangulation import robust_triangulate
    from gaitcap.simulator import make_trial
    from gaitcap.simulator.board import BoardMotion, board_trajectory, observe_board

    trial = make_trial(preset="paper", seconds=10.0, cameras=10, seed=seed)
    rig = trial.rig
    board = make_board(BoardConfig.checkerboard() if board_kind == "checkerboard" else BoardConfig.charuco())
    motion = BoardMotion(n_frames=frames, floor_frames=floor_frames, seed=seed, floor_spots_mm=FLOOR_SPOTS_MM)
    rot, tvec = board_trajectory(board.geometry, motion, rig)
    obs = observe_board(rig, board.geometry, rot, tvec, noise_px=noise_px, scramble=True, seed=seed + 1,
                        still_floor=still_floor)
    t0 = time.perf_counter()
    res = calibrate_from_observations(obs)
    seconds = time.perf_counter() - t0
    centre = np.array([np.linalg.norm(a.center_mm - b.center_mm) for a, b in zip(rig, res.rig, strict=True)])
    angle = np.array([rotation_angle_deg(a.rotation, b.rotation) for a, b in zip(rig, res.rig, strict=True)])
    focal = np.array([b.matrix_px[0, 0] / a.matrix_px[0, 0] - 1 for a, b in zip(rig, res.rig, strict=True)])
    k1 = np.array([b.dist[0] - a.dist[0] for a, b in zip(rig, res.rig, strict=True)])
    walk_true = robust_triangulate(trial.detections, rig).points_mm
    walk_cal = robust_triangulate(trial.detections, res.rig).points_mm
    mpjpe = float(np.nanmean(np.linalg.norm(walk_cal - walk_true, axis=-1)))
    rep = res.report
    return {
        "board": board.geometry.name, "frames": frames, "floor_frames": floor_frames, "noise_px": noise_px,
        "views": int(obs.views().sum()), "corners": rep.n_corners, "outliers": rep.n_outliers,
        "views_left_out": sum(q.views_left_out for q in rep.cameras),
        "seconds": seconds, "centre_err_mm_mean": float(centre.mean()), "centre_err_mm_max": float(centre.max()),
        "rotation_err_deg_mean": float(angle.mean()), "rotation_err_deg_max": float(angle.max()),
        "focal_err_pct_max": float(100 * np.abs(focal).max()), "k1_err_max": float(np.abs(k1).max()),
        "reprojection_rms_px": rep.reprojection_rms_px, "noise_rms_px": float(noise_px * np.sqrt(2)),
        "reprojection_p95_px": rep.reprojection_p95_px, "square_residual_pct": rep.square_residual_pct,
        "walk_mpjpe_vs_true_calibration_mm": mpjpe, "failed_cameras": list(rep.failed_cameras),
        "meets_targets": bool(centre.max() < TARGET_CENTRE_MM and angle.max() < TARGET_ROTATION_DEG
                              and mpjpe < TARGET_MPJPE_MM),
    }


def _detector(board_kind: str, frames: int, scale: float, seed: int) -> dict:
    from gaitcap.acquisition.boards.detection import BoardConfig, make_board
    from gaitcap.simulator.board import (
        BoardMotion,
        board_trajectory,
        observe_board,
        render_board_images,
        scaled_rig,
    )
    from gaitcap.simulator.room import build_rig

    rig = build_rig(10, seed=seed).subset(["cam01", "cam02"])
    board = make_board(BoardConfig.checkerboard() if board_kind == "checkerboard" else BoardConfig.charuco())
    rot, tvec = board_trajectory(board.geometry, BoardMotion(n_frames=frames, floor_frames=1, seed=seed), rig)
    images = render_board_images(rig, board, rot, tvec, scale=scale, seed=seed)
    truth = observe_board(scaled_rig(rig, scale), board.geometry, rot, tvec, noise_px=0.0)
    errors, times, found = [], [], 0
    for c, cam in enumerate(rig.names):
        for i in range(frames):
            t0 = time.perf_counter()
            corners = board.detect(images[cam][i])
            times.append(time.perf_counter() - t0)
            if corners is None or not truth.views()[c, i]:
                continue
            found += 1
            err = min(np.nanmax(np.linalg.norm(corners - truth.corners_px[c, i][list(p)], axis=-1))
                      for p in board.geometry.symmetries)
            errors.append(err)
    h, w = images[rig.names[0]].shape[1:]
    return {
        "image_px": [int(w), int(h)], "images": len(times), "expected_views": int(truth.views().sum()),
        "found_views": found, "view_max_err_px_median": float(np.median(errors)) if errors else float("nan"),
        "view_max_err_px_p95": float(np.percentile(errors, 95)) if errors else float("nan"),
        "ms_per_image": 1000 * float(np.mean(times)),
    }


def _end_to_end(board_kind: str, frames: int, scale: float, seed: int) -> dict:
    """Rendered images of all 10 cameras -> MCAP -> detection -> calibration, against the true rig."""
    import tempfile
    from pathlib import Path

    from gaitcap.acquisition.boards.detection import BoardConfig
    from gaitcap.acquisition.boards.recording import calibrate_from_recording
    from gaitcap.reconstruction.calibration.compare import compare_rigs
    from gaitcap.reconstruction.camera import Rig
    from gaitcap.simulator.board_clip import BoardClipConfig, write_board_clip
    from gaitcap.simulator.board_render import camera_at

    config = BoardConfig.checkerboard() if board_kind == "checkerboard" else BoardConfig.charuco()
    clip = BoardClipConfig(board=config, frames=frames, scale=scale, seed=seed, floor_spots_mm=FLOOR_SPOTS_MM)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        mcap, truth = write_board_clip(Path(tmp) / "board.mcap", clip)
        t1 = time.perf_counter()
        res = calibrate_from_recording(mcap, board=config)
        t2 = time.perf_counter()
    cmp = compare_rigs(truth, res.rig)
    mpjpe = _walk_mpjpe(Rig(tuple(camera_at(cam, 1 / scale) for cam in res.rig)), seed)
    return {
        "frames": frames, "image_px": list(truth[0].size_px), "seconds_render": t1 - t0,
        "seconds_detect_and_calibrate": t2 - t1, "views": sum(q.n_detections for q in res.report.cameras),
        "centre_err_mm_max": cmp.centre_mm_max, "rotation_err_deg_max": cmp.rotation_deg_max,
        "centre_err_mm_mean": float(np.mean([c.centre_mm for c in cmp.cameras])),
        "rig_shape_err_mm_max": cmp.aligned_centre_mm_max, "world_tilt_deg": cmp.world_tilt_deg,
        "world_heading_deg": cmp.world_heading_deg, "world_shift_mm": cmp.world_shift_mm,
        "focal_err_pct_max": max(abs(c.focal_pct) for c in cmp.cameras),
        "reprojection_rms_px": res.report.reprojection_rms_px, "outliers": res.report.n_outliers,
        "walk_mpjpe_vs_true_calibration_mm": mpjpe,
        "meets_targets": bool(cmp.centre_mm_max < TARGET_CENTRE_MM and cmp.rotation_deg_max < TARGET_ROTATION_DEG
                              and mpjpe < TARGET_MPJPE_MM),
    }


def _walk_mpjpe(rig, seed: int) -> float:
    """MPJPE (mm) of a walk triangulated with ``rig`` (full resolution) against the true calibration's."""
    from gaitcap.reconstruction.triangulation import robust_triangulate
    from gaitcap.simulator import make_trial

    trial = make_trial(preset="paper", seconds=10.0, cameras=10, seed=seed)
    walk_true = robust_triangulate(trial.detections, trial.rig).points_mm
    walk_cal = robust_triangulate(trial.detections, rig.subset(trial.rig.names)).points_mm
    return float(np.nanmean(np.linalg.norm(walk_cal - walk_true, axis=-1)))


def _testdata():
    return share_path("testdata", "calibration")


REAL_SESSIONS = {"caliscope-4cam": "caliscope 4_cam_recording (4 webcams 1280x720)",
                 "caliscope-4cam-2": "caliscope post_optimization (another 4-webcam recording of the same board)"}


REAL_VARIANTS = ((True, 0.0), (False, 0.0), (True, 20.0), (False, 20.0))  # (known intrinsics, readout ms)
# frame times there are nominal (frame_index / 30 s, the same in every camera): no readout variants
LARGE_SESSIONS = {"caliscope-11cam": "caliscope larger_calibration_post_monocal (11 cameras 1920x1080) vs its "
                                     "bundle-adjusted calibration (point_estimate_creation/fully_linked)"}


def _real_session(name: str, known_intrinsics: bool, readout_ms: float = 0.0, sync_every: int = 1) -> dict | None:
    """A caliscope 4-webcam ChArUco session, calibrated here and compared with caliscope's calibration
    (readout_ms: views whose board moved more than 1 px within this rolling-shutter readout tie no cameras)."""
    from gaitcap.acquisition.boards.pairing import PairingConfig
    from gaitcap.acquisition.importers.caliscope import read_session
    from gaitcap.reconstruction.calibration import CalibrationConfig, calibrate_from_observations
    from gaitcap.reconstruction.calibration.compare import compare_similar

    folder = _testdata() / name
    if not (folder / "camera_array.toml").exists():
        return None
    t0 = time.perf_counter()
    board, obs, ref, moving = read_session(folder, pairing=PairingConfig(readout_ms=readout_ms), sync_every=sync_every)
    known = {c.name: (c.matrix_px, c.dist) for c in ref.cameras} if known_intrinsics else None
    what = {"recording": {**REAL_SESSIONS, **LARGE_SESSIONS}[name], "board": board.describe(), "readout_ms": readout_ms,
            "sync_every": sync_every,
            "intrinsics": "caliscope's (held fixed)" if known_intrinsics else "estimated from this clip (k1)"}
    try:
        res = calibrate_from_observations(obs, config=CalibrationConfig(known_intrinsics=known))
    except ValueError as exc:
        return {**what, "error": str(exc), "meets_targets": False}
    seconds = time.perf_counter() - t0
    cmp = compare_similar(ref, res.rig)
    cams = res.report.cameras
    out = {
        **what,
        "cameras": [q.name for q in cams], "views_found": obs.views().sum(1).tolist(), "views_moving": moving,
        "views_used": [q.n_detections for q in cams], "views_left_out": [q.views_left_out for q in cams],
        "rms_px": [q.reprojection_rms_px for q in cams],
        "p95_px": [q.reprojection_p95_px for q in cams], "failed": list(res.report.failed_cameras),
        "problems": {q.name: list(q.problems) for q in cams if q.problems},
        "notes": {q.name: list(q.notes) for q in cams if q.notes}, "seconds": seconds,
        "square_measured_mm": res.report.square_measured_mm, "scale_vs_reference": cmp.scale,
        "centre_diff_mm": list(cmp.centre_mm), "rotation_diff_deg": list(cmp.rotation_deg),
        "pointing_diff_deg": list(cmp.pointing_deg),
        "reference_pp_off_centre_deg": [_pp_off_centre_deg(ref[n]) for n in cmp.names],
        "principal_points_apart_deg": [_pp_apart_deg(res.rig[n], ref[n]) for n in cmp.names],
        "principal_point_held": [bool(np.allclose(c.matrix_px[:2, 2], np.asarray(c.size_px) / 2)) for c in res.rig],
        "held": {q.name: list(q.held) for q in cams if q.held},
        "focal_rel_std": [q.focal_rel_std for q in cams],
    }
    # a failed camera (or a NaN RMS) misses the targets: max() would pass over a NaN after a finite value
    rms_ok = bool(np.all(np.isfinite(out["rms_px"])) and max(out["rms_px"]) <= REAL_TARGET_RMS_PX)
    out["meets_targets"] = bool(rms_ok and not out["failed"] and cmp.centre_mm_max <= REAL_TARGET_CENTRE_MM
                                and cmp.rotation_deg_max <= REAL_TARGET_ROTATION_DEG)
    return out


def _reference_fit(name: str, readout_ms: float) -> dict | None:
    """caliscope's own calibration (its camera_array.toml, intrinsics and poses held) on the same corners:
    each frame set's board pose fitted with its cameras fixed, then reprojected, as our report computes it."""
    from gaitcap.acquisition.boards.pairing import PairingConfig
    from gaitcap.acquisition.importers.caliscope import read_session
    from gaitcap.reconstruction.calibration.refit import fit_board_to_rig

    folder = _testdata() / name
    if not (folder / "camera_array.toml").exists():
        return None
    _, obs, ref, moving = read_session(folder, pairing=PairingConfig(readout_ms=readout_ms))
    fit = fit_board_to_rig(obs, ref)
    return {"recording": REAL_SESSIONS[name], "readout_ms": readout_ms, "views_moving": moving,
            "cameras": list(fit.cameras), "views_used": list(fit.views), "rms_px": list(fit.rms_px),
            "p95_px": list(fit.p95_px), "rms_all_px": list(fit.rms_all_px), "outliers": list(fit.outliers),
            "meets_rms_target": bool(np.all(np.isfinite(fit.rms_px)) and max(fit.rms_px) <= REAL_TARGET_RMS_PX)}


def _pp_apart_deg(cam, ref) -> float:
    """How far (degrees of view) two calibrations of a camera put its principal point apart."""
    return float(np.degrees(np.arctan(np.linalg.norm((cam.matrix_px[:2, 2] - ref.matrix_px[:2, 2])
                                                     / np.diag(ref.matrix_px)[:2]))))


def _pp_off_centre_deg(cam) -> float:
    """How far (degrees of view) a camera's principal point lies from its image centre: holding it at the
    centre turns the camera by about this much."""
    off = (cam.matrix_px[:2, 2] - np.asarray(cam.size_px) / 2) / np.diag(cam.matrix_px)[:2]
    return float(np.degrees(np.arctan(np.linalg.norm(off))))


def _real_images(name: str, pattern: str, board) -> dict | None:
    """How many of a folder's real board images the detector finds, and how fast."""
    import cv2
    from gaitcap.acquisition.boards.detection import make_board

    paths = sorted(_testdata().glob(pattern))
    if not paths:
        return None
    detector = make_board(board)
    found, t0 = 0, time.perf_counter()
    for p in paths:
        found += detector.detect(cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)) is not None
    h, w = cv2.imread(str(paths[0]), cv2.IMREAD_GRAYSCALE).shape
    return {"recording": name, "board": board.describe(), "images": len(paths), "image_px": [w, h],
            "found": found, "ms_per_image": 1000 * (time.perf_counter() - t0) / len(paths)}


def _pose2sim_intrinsics() -> dict | None:
    """Pose2Sim's demo intrinsics images (real, 4 cameras, a 8 x 5 checkerboard of 60 mm): the board found,
    each camera's intrinsics (k1) from its views, and the focal length against Qualisys's calibration of
    the same cameras."""
    import cv2
    from gaitcap.acquisition.boards.detection import BoardConfig, make_board
    from gaitcap.acquisition.importers.tool_folders import read_qca
    from gaitcap.reconstruction.calibration import BoardObservations, IntrinsicsConfig
    from gaitcap.reconstruction.calibration.intrinsics import estimate_intrinsics

    folder = _testdata() / "pose2sim-single"
    if not (folder / "calibration" / "Calib.qca.txt").exists():
        return None
    config = BoardConfig.checkerboard(8, 5, 60.0)
    board = make_board(config)
    focal_ref = {c.name: float(c.matrix_px[0, 0]) for c in read_qca(folder / "calibration" / "Calib.qca.txt")}
    out = {"recording": "Pose2Sim demo intrinsics images (4 cameras, 1088x1920)", "board": config.describe(),
           "cameras": {}}
    t0, n_images = time.perf_counter(), 0
    for cam, ref in sorted(focal_ref.items()):
        paths = sorted((folder / "calibration" / "intrinsics" / f"int_{cam}_img").glob("*.jpg"))
        found = [c for c in (board.detect(cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)) for p in paths) if c is not None]
        n_images += len(paths)
        h, w = cv2.imread(str(paths[0]), cv2.IMREAD_GRAYSCALE).shape
        entry = {"images": len(paths), "found": len(found), "qualisys_focal_px": ref}
        if len(found) >= 3:
            obs = BoardObservations((cam,), ((w, h),), np.stack(found)[None], board.geometry)
            intr = estimate_intrinsics(obs, 0, IntrinsicsConfig(min_views=3, min_tilted_views=2))
            entry.update(focal_px=float(intr.matrix_px[0, 0]), focal_diff_pct=float(100 * (intr.matrix_px[0, 0] / ref - 1)),
                         rms_px=intr.rms_px)
        out["cameras"][cam] = entry
    out["ms_per_image"] = 1000 * (time.perf_counter() - t0) / n_images
    return out


def _real(sync_every: int = 1) -> dict:
    from gaitcap.acquisition.boards.detection import BoardConfig

    return {
        "sessions": [r for r in (_real_session(n, k, ro) for n in REAL_SESSIONS for k, ro in REAL_VARIANTS)
                     if r is not None]
        + [r for r in (_real_session(n, k, 0.0, sync_every) for n in LARGE_SESSIONS for k in (True, False))
           if r is not None],
        "caliscope_own": [r for r in (_reference_fit(n, ro) for n in REAL_SESSIONS
                                      for ro in sorted({ro for _, ro in REAL_VARIANTS})) if r is not None],
        "images": [r for r in (
            _real_images("caliscope checkerboard frames (webcams 1280x720)", "caliscope-chessboard/*.jpg",
                         BoardConfig.checkerboard(10, 7, 25.0)),
        ) if r is not None],
        "intrinsics": _pose2sim_intrinsics(),
        "opencv": opencv_samples(),
    }


def _equal_terms(obs, ref, clip, given, known_config, holdout) -> dict:
    """gaitcap's held-out error against caliscope's own calibration fitted on the same folds' frame sets
    (its scripting API) and judged on the same held-out ones, each side given the same intrinsic inputs:
    ``clip`` the board clip alone (gaitcap's default rule; caliscope's intrinsic calibration of the clip),
    ``given`` caliscope's intrinsics (from its separate intrinsics session, in its camera_array.toml) held
    by both (cross_validate comparisons with ``refitted``); then gaitcap's fit chosen by held-out error
    (loss; caliscope's intrinsics held or the clip's) against caliscope's pipeline with its intrinsics,
    the two as a user would run them."""
    from gaitcap.acquisition.importers.caliscope import calibrate_with_caliscope
    from gaitcap.reconstruction.calibration import calibrate_from_observations
    from gaitcap.reconstruction.calibration.holdout import cross_validate
    from gaitcap.reconstruction.calibration.model_choice import choose_fit

    def pair(cmp) -> dict:
        return {"gaitcap": _figures(cmp.own), "caliscope": _figures(cmp.refitted), "frame_sets": cmp.own.frame_sets,
                "fold_errors": list(cmp.own.fold_errors), "gaitcap_seconds": cmp.own.seconds,
                "caliscope_seconds": cmp.refitted.seconds}

    out = {"clip": pair(clip), "given": pair(given)}
    t0 = time.perf_counter()
    # the default fit with and without caliscope's intrinsics was cross-validated above (not reused where
    # a fold was left out because caliscope's fit failed: gaitcap's figure would then miss that fold)
    done = {label: cmp.own for label, cmp in (("given intrinsics held, soft-L1 (1 px)", given),
                                              ("intrinsics from the clip, soft-L1 (1 px)", clip))
            if not any(cmp.refitted.label in e for e in cmp.own.fold_errors)}
    chosen_config, fit = choose_fit(obs, known_config, holdout=holdout, evaluated=done)
    out["fit_choice"] = {**fit.to_dict(), "seconds": time.perf_counter() - t0}
    if fit.chosen == "given intrinsics held, soft-L1 (1 px)":
        out["chosen"] = out["given"]
    else:
        out["chosen"] = pair(cross_validate(obs, lambda o: calibrate_from_observations(o, config=chosen_config).rig,
                                           config=holdout, refit=lambda o: calibrate_with_caliscope(o, ref),
                                           refit_label="caliscope's calibration, its intrinsics"))
    return out


def _figures(e) -> dict:
    return {"rms_px": [c.rms_px for c in e.cameras], "rms_inlier_px": [c.rms_inlier_px for c in e.cameras],
            "rig_rms_px": e.rms_px, "square_mm": e.board.square_mm, "square_error_rms_mm": e.board.square_error_rms_mm,
            "flatness_rms_mm": e.board.flatness_rms_mm, "problems": list(e.problems)}


def _held_out(name: str, sync_every: int, folds: int, choose: bool) -> dict | None:
    """The session's held-out error (``folds`` in time): gaitcap's calibration (intrinsics from the clip,
    held by coverage or, with ``choose``, chosen per camera by held-out error) fitted on the other folds,
    and caliscope's calibration judged the same way on the same frame sets (made from all of them)."""
    from gaitcap.acquisition.importers.caliscope import (
        calibrate_with_caliscope,
        caliscope_available,
        read_session,
    )
    from gaitcap.reconstruction.calibration import CalibrationConfig, calibrate_from_observations
    from gaitcap.reconstruction.calibration.compare import compare_similar
    from gaitcap.reconstruction.calibration.holdout import HoldoutConfig, cross_validate, evaluate_rig
    from gaitcap.reconstruction.calibration.model_choice import choose_intrinsics, fit_candidates
    from gaitcap.reconstruction.calibration.motion import MotionConfig

    folder = _testdata() / name
    if not (folder / "camera_array.toml").exists():
        return None
    fair = caliscope_available()
    if not fair:
        logging.warning("caliscope's scripting API is not installed (pip install -e '.[caliscope]'): its "
                        "calibration is judged only as made from every frame set (in-sample), not per fold")
    _, obs, ref, _ = read_session(folder, sync_every=sync_every)
    holdout = HoldoutConfig(folds=folds)
    config, choice, choice_error = CalibrationConfig(), None, None
    if choose:
        try:
            config, choice = choose_intrinsics(obs, config, holdout=holdout)
        except ValueError as exc:  # no candidate fitted in every fold: the default rule, said
            choice_error = str(exc)
    t0 = time.perf_counter()
    rig = calibrate_from_observations(obs, config=config).rig
    fit_s = time.perf_counter() - t0
    # with caliscope's scripting API, caliscope's own calibration is fitted on the same folds too (from the
    # clip alone; with its intrinsics below): judged on equal terms
    cmp = cross_validate(obs, lambda o: calibrate_from_observations(o, config=config).rig, reference=ref,
                         reference_label="caliscope's", config=holdout,
                         refit=calibrate_with_caliscope if fair else None,
                         refit_label="caliscope's calibration, intrinsics from the clip")
    # caliscope's intrinsics held, the poses fitted here on the same folds: caliscope's intrinsics judged on
    # equal terms (held out), and what the poses alone leave
    known = replace(config, known_intrinsics={c.name: (c.matrix_px, c.dist) for c in ref.cameras})
    given = cross_validate(obs, lambda o: calibrate_from_observations(o, config=known).rig, config=holdout,
                           refit=(lambda o: calibrate_with_caliscope(o, ref)) if fair else None,
                           refit_label="caliscope's calibration, its intrinsics")
    their_intr = given.own
    moving = replace(config, motion=MotionConfig())  # the board's motion modelled (time offsets, speed weights)
    motion = calibrate_from_observations(obs, config=moving).report.motion
    with_motion = (cross_validate(obs, lambda o: calibrate_from_observations(o, config=moving).rig,
                                  config=holdout).own if "root" in motion and np.isfinite(motion["offsets_ms"]).any()
                   else None)
    in_sample = evaluate_rig(obs, rig, label="gaitcap (all frame sets)")
    similar = compare_similar(ref, rig)
    own, theirs = cmp.own, cmp.reference
    # with ``choose``, gaitcap's clip candidates carry the intrinsics chosen per camera (``config``)
    equal = _equal_terms(obs, ref, cmp, given, known, holdout) if fair else None
    if equal is not None:  # the chosen fit's rig (every frame set) against caliscope's, and who holds out better
        fit_config = next(c for lab, c in fit_candidates(known).items() if lab == equal["fit_choice"]["chosen"])
        chosen_similar = compare_similar(ref, calibrate_from_observations(obs, config=fit_config).rig)
        c = equal["chosen"]
        equal["chosen_vs_caliscope"] = {
            "centre_diff_mm_max": chosen_similar.centre_mm_max, "rotation_diff_deg_max": chosen_similar.rotation_deg_max,
            "rigs_apart": bool(chosen_similar.centre_mm_max > REAL_TARGET_CENTRE_MM
                               or chosen_similar.rotation_deg_max > REAL_TARGET_ROTATION_DEG),
            "better_held_out": "gaitcap" if c["gaitcap"]["rig_rms_px"] <= c["caliscope"]["rig_rms_px"] else "caliscope",
            "meets_target_rig": bool(c["gaitcap"]["rig_rms_px"] <= c["caliscope"]["rig_rms_px"]),
            "cameras_at_or_below": int(sum(a <= b for a, b in zip(c["gaitcap"]["rms_px"], c["caliscope"]["rms_px"],
                                                                   strict=True)))}

    figures = _figures
    apart = similar.centre_mm_max > REAL_TARGET_CENTRE_MM or similar.rotation_deg_max > REAL_TARGET_ROTATION_DEG
    return {
        "recording": {**REAL_SESSIONS, **LARGE_SESSIONS}[name], "sync_every": sync_every, "folds": folds,
        "intrinsics": "chosen per camera by held-out error" if choice else "held by coverage (the default)",
        "choice_error": choice_error,
        "chosen": choice.chosen if choice else None, "choice_rms_px": choice.held_out_rms_px if choice else None,
        "choice_candidates": list(choice.candidates) if choice else None,
        "choice_seconds": choice.seconds if choice else 0.0, "shared_focal": choice.shared_focal if choice else None,
        "choice_fallback": choice.fallback if choice else None,
        "choice_rig_rms_px": list(choice.rig_rms_px) if choice else None,
        "cameras": list(obs.camera_names),
        "frame_sets": own.frame_sets, "fold_errors": list(own.fold_errors), "fit_seconds": fit_s,
        "folds_seconds": own.seconds, "gaitcap": figures(own), "caliscope": figures(theirs),
        "gaitcap_in_sample": figures(in_sample), "caliscope_intrinsics_held_out": figures(their_intr),
        "motion_notes": list(motion.get("notes", ())),
        "motion_held_out": figures(with_motion) if with_motion is not None else None,
        "centre_diff_mm_max": similar.centre_mm_max,
        "rotation_diff_deg_max": similar.rotation_deg_max, "rigs_apart": bool(apart),
        "better_held_out": "gaitcap" if own.rms_px < theirs.rms_px else "caliscope",
        "equal_terms": equal,
        "meets_target": bool(all(a <= b for a, b in zip(figures(own)["rms_px"], figures(theirs)["rms_px"],
                                                            strict=True))),
    }


def _small_board(sync_every: int, folds: int = 0, choose: bool = False, only: list[str] | None = None) -> list[dict]:
    """The real small-board sessions (the board in 10-28 % of the images), intrinsics from the clip alone:
    what was held, refused or not, and each camera against the session's reference calibration; with
    ``folds`` also the held-out error, gaitcap's against caliscope's on the same frame sets (``only``: these
    sessions)."""
    names = tuple(n for n in (*REAL_SESSIONS, *LARGE_SESSIONS) if not only or n in only)
    out = [r for r in (_real_session(n, False, 0.0, sync_every if n in LARGE_SESSIONS else 1) for n in names)
           if r is not None]
    if folds:
        held = [h for h in (_held_out(n, sync_every if n in LARGE_SESSIONS else 1, folds, choose) for n in names)
                if h is not None]
        for r, h in zip(out, held, strict=True):
            r["held_out"] = h
    return out


def _held_out_lines(h: dict) -> list[str]:
    lines = [f"    held-out error ({h['folds']} folds in time, {h['frame_sets']} frame sets; intrinsics {h['intrinsics']}; "
             f"folds {h['folds_seconds']:.0f} s, one fit {h['fit_seconds']:.1f} s"
             + (f", choice {h['choice_seconds']:.0f} s" if h["chosen"] else "") + "):"]
    lines.append(f"    {'camera':<8} {'gaitcap':>8} {'caliscope':>10} {'in-sample':>10} {'cs intr':>8}  (RMS px over all "
                 "held-out corners; cs intr: caliscope's intrinsics held, poses fitted here on the same folds)"
                 + ("  chosen" if h["chosen"] else ""))
    for k, cam in enumerate(h["cameras"]):
        chosen = f"  {h['chosen'][cam]}" if h["chosen"] else ""
        lines.append(f"    {cam:<8} {h['gaitcap']['rms_px'][k]:>8.3f} {h['caliscope']['rms_px'][k]:>10.3f} "
                     f"{h['gaitcap_in_sample']['rms_px'][k]:>10.3f} "
                     f"{h['caliscope_intrinsics_held_out']['rms_px'][k]:>8.3f}{chosen}")
    lines.append(f"    caliscope's intrinsics, poses fitted here, held out: rig RMS "
                 f"{h['caliscope_intrinsics_held_out']['rig_rms_px']:.3f} px")
    lines += [f"    motion model: {n}" for n in h["motion_notes"]]
    if h["motion_held_out"] is not None:
        m = h["motion_held_out"]
        lines.append(f"    with the board's motion modelled, held out: {' / '.join(f'{r:.3f}' for r in m['rms_px'])} px, "
                     f"rig {m['rig_rms_px']:.3f} px")
    for who in ("gaitcap", "caliscope"):
        f = h[who]
        lines.append(f"    {who}: rig RMS {f['rig_rms_px']:.3f} px; board in 3D: square {f['square_mm']:.2f} mm, "
                     f"error RMS {f['square_error_rms_mm']:.2f} mm, flatness {f['flatness_rms_mm']:.2f} mm"
                     + "".join(f"; {p}" for p in f["problems"]))
    apart = (f"rigs {h['centre_diff_mm_max']:.1f} mm / {h['rotation_diff_deg_max']:.2f} deg apart: "
             + (f"beyond 15 mm / 1 deg, the held-out error favours {h['better_held_out']}" if h["rigs_apart"]
                else "within 15 mm / 1 deg"))
    lines.append(f"    {apart}; target (gaitcap's held-out RMS <= caliscope's, every camera): "
                 f"{'met' if h['meets_target'] else 'NOT met'} (caliscope's calibration was made from these frame "
                 "sets: in-sample for it)")
    lines += [f"    fold not fitted: {e}" for e in h["fold_errors"]]
    if h.get("equal_terms"):
        lines += _equal_lines(h["equal_terms"], h["cameras"])
    lines += [f"    {h['choice_fallback']}"] if h.get("choice_fallback") else []
    lines += [f"    {h['shared_focal']}"] if h.get("shared_focal") else []
    lines += [f"    intrinsics not chosen: {h['choice_error']}"] if h.get("choice_error") else []
    return lines


def _equal_lines(e: dict, cameras: list[str]) -> list[str]:
    """The held-out error on equal terms: caliscope's own calibration fitted per fold (its scripting API)."""
    rows = (("clip", "from the clip alone (gaitcap: its intrinsics rule, above; caliscope: its calibrate_intrinsics of "
                     "the clip)"),
            ("given", "caliscope's intrinsics (its intrinsics session) held by both"),
            ("chosen", f"gaitcap's fit chosen by held-out error ({e['fit_choice']['chosen']}) vs caliscope with its "
                       "intrinsics"))
    lines = ["    on equal terms: caliscope's own calibration (scripting API) fitted on each fold's frame sets as "
             "gaitcap's is, both judged on the same held-out sets (RMS px, gaitcap / caliscope):"]
    for key, what in rows:
        r = e[key]
        per = "  ".join(f"{cam} {g:.3f}/{c:.3f}" for cam, g, c in zip(cameras, r["gaitcap"]["rms_px"], r["caliscope"]["rms_px"],
                                                                      strict=True))
        lines.append(f"      {what}: rig {r['gaitcap']['rig_rms_px']:.3f} / {r['caliscope']['rig_rms_px']:.3f} "
                     f"({r['frame_sets']} frame sets; fits {r['gaitcap_seconds']:.0f} / {r['caliscope_seconds']:.0f} s)")
        lines.append(f"        {per}")
        lines += [f"        fold not judged: {x}" for x in r["fold_errors"]]
    f = e["fit_choice"]
    lines.append("      fit candidates, rig RMS held out: " + "; ".join(
        f"{lab} " + (f"{r:.3f}" if r is not None and np.isfinite(r) else "not fitted in every fold")
        for lab, r in zip(f["candidates"], f["rig_rms_px"], strict=True)) + f" ({f['seconds']:.0f} s)")
    v = e["chosen_vs_caliscope"]
    lines.append(f"      chosen fit's rig vs caliscope's: {v['centre_diff_mm_max']:.1f} mm / {v['rotation_diff_deg_max']:.2f} deg"
                 + (f" apart (beyond 15 mm / 1 deg): the held-out error favours {v['better_held_out']}" if v["rigs_apart"]
                    else " (within 15 mm / 1 deg)")
                 + f"; target (gaitcap's held-out RMS <= caliscope's, rig): {'met' if v['meets_target_rig'] else 'NOT met'}"
                 f", {v['cameras_at_or_below']} of {len(cameras)} cameras at or below")
    return lines


def _small_board_table(sessions: list[dict]) -> str:
    lines = ["small-board sessions, intrinsics from the clip alone, vs the session's reference calibration "
             "(after a similarity alignment):"]
    for s in sessions:
        if "error" in s:
            lines.append(f"  {s['recording']}: REFUSED: {s['error']}")
            continue
        state = f"REFUSED (cameras {s['failed']} failed)" if s["failed"] else "calibrated"
        every = f", every {s['sync_every']}th sync index" if s["sync_every"] > 1 else ""
        lines.append(f"  {s['recording']}{every}: {state}, {s['seconds']:.1f} s, scale {s['scale_vs_reference']:.4f}")
        lines.append(f"    {'camera':<8} {'RMS px':>7} {'f std %':>8} {'centre mm':>10} {'rot deg':>8} {'ray deg':>8}  held")
        for k, cam in enumerate(s["cameras"]):
            held = "; ".join(s["held"].get(cam, [])) or "-"
            lines.append(f"    {cam:<8} {s['rms_px'][k]:>7.3f} {100 * s['focal_rel_std'][k]:>8.1f} "
                         f"{s['centre_diff_mm'][k]:>10.2f} {s['rotation_diff_deg'][k]:>8.3f} "
                         f"{s['pointing_diff_deg'][k]:>8.3f}  {held}")
        lines.append(f"    max: centre {max(s['centre_diff_mm']):.1f} mm, rotation {max(s['rotation_diff_deg']):.2f} deg "
                     f"(ray deg: the rays through the image centre)")
        if "held_out" in s:
            lines += _held_out_lines(s["held_out"])
    return "\n".join(lines)


def _real_table(r: dict) -> str:
    lines = ["real recordings:"]
    for s in r["sessions"]:
        if "error" in s:
            lines.append(f"  {s['recording']}; intrinsics {s['intrinsics']}, readout {s['readout_ms']:.0f} ms: "
                         f"refused: {s['error']}")
            continue
        readout = f"; moving over a {s['readout_ms']:.0f} ms readout" if s["readout_ms"] else ""
        lines.append(f"  {s['recording']}, {s['board']}; intrinsics {s['intrinsics']}{readout}: {s['seconds']:.1f} s, "
                     f"square {s['square_measured_mm']:.2f} mm, scale vs caliscope {s['scale_vs_reference']:.4f}, "
                     f"{s['views_moving']} views taken out (board moving between the exposures, or during the readout)")
        lines.append(f"    {'camera':<8} {'views':>6} {'used':>5} {'RMS px':>7} {'p95 px':>7} {'centre mm':>10} "
                     f"{'rot deg':>8} {'ray deg':>8} {'ref pp deg':>10}  status")
        for k, cam in enumerate(s["cameras"]):
            status = "; ".join(s["problems"].get(cam, [])) or "ok"
            status += "".join(f"; {n}" for n in s["notes"].get(cam, []))
            held = " (principal point held at the image centre)" if s["principal_point_held"][k] else ""
            lines.append(f"    {cam:<8} {s['views_found'][k]:>6} {s['views_used'][k]:>5} {s['rms_px'][k]:>7.3f} "
                         f"{s['p95_px'][k]:>7.3f} {s['centre_diff_mm'][k]:>10.2f} {s['rotation_diff_deg'][k]:>8.3f} "
                         f"{s['pointing_diff_deg'][k]:>8.3f} {s['reference_pp_off_centre_deg'][k]:>10.2f}  "
                         f"{status}{held}")
        if s["sync_every"] > 1:
            lines.append(f"    (every {s['sync_every']}th sync index)")
        if not s["intrinsics"].startswith("caliscope"):
            lines.append("    principal points apart (deg of view), ours vs caliscope's: "
                         + " ".join(f"{d:.2f}" for d in s["principal_points_apart_deg"]))
        lines.append("    (ray deg: the two calibrations' rays through the image centre; ref pp deg: caliscope's "
                     "principal point off the image centre)")
        lines.append(f"    targets (RMS <= {REAL_TARGET_RMS_PX} px, centres <= {REAL_TARGET_CENTRE_MM} mm, rotations <= "
                     f"{REAL_TARGET_ROTATION_DEG} deg vs caliscope after a similarity alignment): "
                     f"{'met' if s['meets_targets'] else 'NOT met'}")
    for s in r.get("caliscope_own", []):
        readout = f"; moving over a {s['readout_ms']:.0f} ms readout taken out ({s['views_moving']} views)" \
            if s["readout_ms"] else ""
        lines.append(f"  caliscope's own calibration (camera_array.toml held, board poses fitted) on the same corners, "
                     f"{s['recording']}{readout}: RMS <= {REAL_TARGET_RMS_PX} px "
                     f"{'met' if s['meets_rms_target'] else 'NOT met'}")
        lines.append(f"    {'camera':<8} {'views':>6} {'RMS px':>7} {'p95 px':>7} {'all px':>7} {'outliers':>9}")
        for k, cam in enumerate(s["cameras"]):
            lines.append(f"    {cam:<8} {s['views_used'][k]:>6} {s['rms_px'][k]:>7.3f} {s['p95_px'][k]:>7.3f} "
                         f"{s['rms_all_px'][k]:>7.3f} {s['outliers'][k]:>9}")
        lines.append("    (all px: RMS over all corners, outliers included: the figure the refusal rule judges)")
    for i in r["images"]:
        lines.append(f"  {i['recording']}, {i['board']}: found in {i['found']} of {i['images']} images "
                     f"({i['image_px'][0]}x{i['image_px'][1]}), {i['ms_per_image']:.0f} ms/image")
    if r.get("intrinsics"):
        p = r["intrinsics"]
        lines.append(f"  {p['recording']}, {p['board']} ({p['ms_per_image']:.0f} ms/image), intrinsics (k1) vs "
                     "Qualisys's calibration of the same cameras:")
        for cam, e in p["cameras"].items():
            got = (f"focal {e['focal_px']:.1f} px vs {e['qualisys_focal_px']:.1f} px ({e['focal_diff_pct']:+.2f} %), "
                   f"RMS {e['rms_px']:.3f} px") if "focal_px" in e else "too few views"
            lines.append(f"    {cam}: board found in {e['found']} of {e['images']} images; {got}")
    if r.get("opencv"):
        lines += opencv_lines(r["opencv"], rms_target_px=REAL_TARGET_RMS_PX, centre_target_mm=REAL_TARGET_CENTRE_MM,
                              rotation_target_deg=REAL_TARGET_ROTATION_DEG)
    if not r["sessions"] and not r["images"] and not (r.get("opencv") or {}).get("stereo"):
        lines.append("  none installed (run deploy/bootstrap.sh)")
    return "\n".join(lines)


def _table(r: dict) -> str:
    c, d = r["calibration"], r["detector"] or {"images": 0, "image_px": [0, 0], "found_views": 0, "expected_views": 0,
                                               "view_max_err_px_median": float("nan"),
                                               "view_max_err_px_p95": float("nan"), "ms_per_image": float("nan")}
    rows = [
        ("board", c["board"], ""),
        ("frames (floor) / views / corners", f"{c['frames']} ({c['floor_frames']}) / {c['views']} / {c['corners']}", ""),
        ("outlier corners / views left out", f"{c['outliers']} / {c['views_left_out']}",
         "views disagreeing as a whole (whole_views.py)"),
        ("calibration time", f"{c['seconds']:.1f} s", "2 shared cores, noisy"),
        ("camera centre error mean / max", f"{c['centre_err_mm_mean']:.2f} / {c['centre_err_mm_max']:.2f} mm", f"< {TARGET_CENTRE_MM} mm"),
        ("rotation error mean / max", f"{c['rotation_err_deg_mean']:.3f} / {c['rotation_err_deg_max']:.3f} deg", f"< {TARGET_ROTATION_DEG} deg"),
        ("focal length error max", f"{c['focal_err_pct_max']:.3f} %", ""),
        ("k1 error max", f"{c['k1_err_max']:.4f}", ""),
        ("reprojection RMS / p95", f"{c['reprojection_rms_px']:.3f} / {c['reprojection_p95_px']:.3f} px", f"noise {c['noise_rms_px']:.3f} px"),
        ("square size residual", f"{c['square_residual_pct']:+.3f} %", ""),
        ("walk MPJPE vs true calibration", f"{c['walk_mpjpe_vs_true_calibration_mm']:.2f} mm", f"< {TARGET_MPJPE_MM} mm"),
        ("meets targets", str(c["meets_targets"]), ""),
        ("still floor: centre / rotation max", f"{r['still_floor']['centre_err_mm_max']:.2f} mm / "
         f"{r['still_floor']['rotation_err_deg_max']:.3f} deg", "floor noise repeats in its frames"),
        ("still floor: walk MPJPE, meets targets", f"{r['still_floor']['walk_mpjpe_vs_true_calibration_mm']:.2f} mm, "
         f"{r['still_floor']['meets_targets']}", ""),
        ("detector: images", f"{d['images']} at {d['image_px'][0]}x{d['image_px'][1]}", ""),
        ("detector: views found / expected", f"{d['found_views']} / {d['expected_views']}", ""),
        ("detector: per-view max error median / p95", f"{d['view_max_err_px_median']:.3f} / {d['view_max_err_px_p95']:.3f} px", ""),
        ("detector: time", f"{d['ms_per_image']:.0f} ms/image", "2 shared cores, noisy"),
    ]
    if r.get("end_to_end"):
        e = r["end_to_end"]
        rows += [
            ("images: frames, size, views", f"{e['frames']} x 10 cameras, {e['image_px'][0]}x{e['image_px'][1]}, "
             f"{e['views']} views", ""),
            ("images: centre error mean / max", f"{e['centre_err_mm_mean']:.2f} / {e['centre_err_mm_max']:.2f} mm",
             f"< {TARGET_CENTRE_MM} mm"),
            ("images: rotation error max", f"{e['rotation_err_deg_max']:.3f} deg", f"< {TARGET_ROTATION_DEG} deg"),
            ("images: rig shape error max", f"{e['rig_shape_err_mm_max']:.2f} mm", "world change taken out"),
            ("images: world tilt / heading / shift", f"{e['world_tilt_deg']:.3f} / {e['world_heading_deg']:.3f} deg / "
             f"{e['world_shift_mm']:.2f} mm", "from the floor board"),
            ("images: focal error max, RMS", f"{e['focal_err_pct_max']:.3f} %, {e['reprojection_rms_px']:.3f} px", ""),
            ("images: time render / detect+calibrate", f"{e['seconds_render']:.0f} / {e['seconds_detect_and_calibrate']:.0f} s", ""),
            ("images: walk MPJPE vs true calibration", f"{e['walk_mpjpe_vs_true_calibration_mm']:.2f} mm",
             f"< {TARGET_MPJPE_MM} mm"),
            ("images: meets targets", str(e["meets_targets"]), ""),
        ]
    width = max(len(k) for k, _, _ in rows)
    return "\n".join(f"{k:<{width}}  {v:<28} {t}" for k, v, t in rows)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--board", choices=["checkerboard", "charuco"], default="checkerboard")
    ap.add_argument("--frames", type=int, default=600, help="board frames (10 fps: 60 s)")
    ap.add_argument("--floor-frames", type=int, default=20, help="frames with the board still on the floor")
    ap.add_argument("--noise-px", type=float, default=0.5, help="corner noise per axis, px")
    ap.add_argument("--detector-frames", type=int, default=20, help="rendered frames per camera (2 cameras; 0 = skip)")
    ap.add_argument("--scale", type=float, default=0.5, help="detector check: rendered image scale (1 = 1920x1200)")
    ap.add_argument("--images", type=int, default=0,
                    help="also calibrate end to end from N rendered frames of all 10 cameras (slow; 0 = skip)")
    ap.add_argument("--image-scale", type=float, default=1.0, help="end-to-end image scale (1 = 1920x1200)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.add_argument("--real-only", action="store_true", help="only the real recordings")
    ap.add_argument("--sync-every", type=int, default=1,
                    help="caliscope's 11-camera session: keep every N-th sync index (1 = all)")
    ap.add_argument("--small-board", action="store_true",
                    help="only the real small-board sessions, intrinsics from the clip (the 11-camera one every "
                         "--sync-every th sync index)")
    ap.add_argument("--folds", type=int, default=0,
                    help="--small-board: also the held-out error, K folds in time (gaitcap's vs caliscope's)")
    ap.add_argument("--choose-intrinsics", action="store_true",
                    help="--small-board --folds K: gaitcap's intrinsics chosen per camera by held-out error")
    ap.add_argument("--session", action="append", choices=[*REAL_SESSIONS, *LARGE_SESSIONS],
                    help="--small-board: only this session (repeatable; default: all three)")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    if args.small_board:
        small = _small_board(args.sync_every, args.folds, args.choose_intrinsics, args.session)
        print(json.dumps(jsonable({"small_board": small})) if args.json else _small_board_table(small))
        return
    if args.real_only:
        real = _real(args.sync_every)
        print(json.dumps(jsonable({"real": real})) if args.json else _real_table(real))
        return
    result = {
        "calibration": _calibration(args.board, args.frames, args.floor_frames, args.noise_px, args.seed),
        "still_floor": _calibration(args.board, args.frames, args.floor_frames, args.noise_px, args.seed,
                                    still_floor=True),
        "detector": _detector(args.board, args.detector_frames, args.scale, args.seed) if args.detector_frames > 1 else None,
        "end_to_end": _end_to_end(args.board, args.images, args.image_scale, args.seed) if args.images else None,
        "real": _real(args.sync_every),
    }
    print(json.dumps(jsonable(result)) if args.json else _table(result) + "\n" + _real_table(result["real"]))


if __name__ == "__main__":
    main()
