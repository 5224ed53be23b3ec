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
"""

from __future__ import annotations

import argparse
import json
import logging
import time

import numpy as np

TARGET_CENTRE_MM = 5.0
TARGET_ROTATION_DEG = 0.2
TARGET_MPJPE_MM = 2.0
FLOOR_SPOTS_MM = ((1500.0, 1500.0), (-1500.0, 1200.0), (1000.0, -1500.0))  # board laid down again here


def _calibration(board_kind: str, frames: int, floor_frames: int, noise_px: float, seed: int,
                 still_floor: bool = False) -> dict:
    from gaitcap.acquisition.board import BoardConfig, make_board
    from gaitcap.acquisition.synthetic import make_trial
    from gaitcap.acquisition.synthetic.board import BoardMotion, board_trajectory, observe_board
    from gaitcap.reconstruction.calibration import calibrate_from_observations
    from gaitcap.reconstruction.calibration.geometry import rotation_angle_deg
    from gaitcap.reconstruction.triangulation import robust_triangulate

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
    from gaitcap.acquisition.board import BoardConfig, make_board
    from gaitcap.acquisition.synthetic.board import (
        BoardMotion,
        board_trajectory,
        observe_board,
        render_board_images,
        scaled_rig,
    )
    from gaitcap.acquisition.synthetic.room import build_rig

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

    from gaitcap.acquisition.board import BoardConfig
    from gaitcap.acquisition.board_recording import calibrate_from_recording
    from gaitcap.acquisition.synthetic.board_clip import BoardClipConfig, write_board_clip
    from gaitcap.acquisition.synthetic.board_render import camera_at
    from gaitcap.reconstruction.calibration.compare import compare_rigs
    from gaitcap.reconstruction.camera import Rig

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
    from gaitcap.acquisition.synthetic import make_trial
    from gaitcap.reconstruction.triangulation import robust_triangulate

    trial = make_trial(preset="paper", seconds=10.0, cameras=10, seed=seed)
    walk_true = robust_triangulate(trial.detections, trial.rig).points_mm
    walk_cal = robust_triangulate(trial.detections, rig.subset(trial.rig.names)).points_mm
    return float(np.nanmean(np.linalg.norm(walk_cal - walk_true, axis=-1)))


def _table(r: dict) -> str:
    c, d = r["calibration"], r["detector"] or {"images": 0, "image_px": [0, 0], "found_views": 0, "expected_views": 0,
                                               "view_max_err_px_median": float("nan"),
                                               "view_max_err_px_p95": float("nan"), "ms_per_image": float("nan")}
    rows = [
        ("board", c["board"], ""),
        ("frames (floor) / views / corners", f"{c['frames']} ({c['floor_frames']}) / {c['views']} / {c['corners']}", ""),
        ("outlier corners", f"{c['outliers']}", ""),
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
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    result = {
        "calibration": _calibration(args.board, args.frames, args.floor_frames, args.noise_px, args.seed),
        "still_floor": _calibration(args.board, args.frames, args.floor_frames, args.noise_px, args.seed,
                                    still_floor=True),
        "detector": _detector(args.board, args.detector_frames, args.scale, args.seed) if args.detector_frames > 1 else None,
        "end_to_end": _end_to_end(args.board, args.images, args.image_scale, args.seed) if args.images else None,
    }
    print(json.dumps(result) if args.json else _table(result))


if __name__ == "__main__":
    main()
