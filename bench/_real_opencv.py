"""The real section of bench/calibration.py for OpenCV's own sample recordings (installed by
deploy/bootstrap.sh from Debian's opencv-doc; skipped when absent).

- The stereo_calib pair (two cameras, 13 synchronised 640x480 views of a 9 x 6 inner-corner checkerboard,
  25 mm squares as OpenCV's calibration file gives them): calibrated here from the images with the board's
  description only, compared with OpenCV's own calibration of the same images. Two cameras leave a
  similarity alignment undetermined, so the pair is compared through its own geometry: the right camera
  seen from the left (baseline, centre, rotation), whatever world frame each calibration chose.
- The ChArUco tutorial's photo of a printed 5 x 7 board (DICT_6X6_250): markers and corners found, and the
  board's pose fitted with the calibration of its camera (OpenCV's file), reprojected.
"""

from __future__ import annotations

import time

import numpy as np
from gaitcap.acquisition.installed import share_path

STEREO_DISTORTIONS = ("k1", "k1k2p1p2k3")  # the paper's model, and OpenCV's five terms


def _stereo(distortion: str) -> dict | None:
    from gaitcap.acquisition.boards.detection import BoardConfig
    from gaitcap.acquisition.boards.recording import calibrate_from_recording
    from gaitcap.acquisition.importers.opencv_samples import opencv_stereo_calibration, read_opencv_camera
    from gaitcap.reconstruction.calibration import CalibrationConfig, IntrinsicsConfig
    from gaitcap.reconstruction.calibration.compare import stereo_difference
    from gaitcap.reconstruction.calibration.intrinsics import DistortionModel

    folder = share_path("testdata", "calibration", "opencv-stereo")
    if not (folder / "left_intrinsics.yml").exists():
        return None
    board = BoardConfig.checkerboard(10, 7, 25.0)
    t0 = time.perf_counter()
    config = CalibrationConfig(intrinsics=IntrinsicsConfig(distortion=DistortionModel(distortion)))
    res = calibrate_from_recording(folder, board=board, config=config)
    seconds = time.perf_counter() - t0
    opencv = opencv_stereo_calibration(sorted((folder / "left").glob("*.jpg")),
                                       sorted((folder / "right").glob("*.jpg")), board=board)
    diff = stereo_difference(opencv.rig, res.rig, first="left", second="right")
    sample = read_opencv_camera(folder / "left_intrinsics.yml", name="left")
    cams = res.report.cameras
    return {
        "recording": "OpenCV stereo_calib sample (2 cameras 640x480, 13 synchronised views)",
        "board": board.describe(), "distortion": distortion, "seconds": seconds,
        "cameras": [q.name for q in cams], "views_found": [q.views_found for q in cams],
        "views_used": [q.n_detections for q in cams], "rms_px": [q.reprojection_rms_px for q in cams],
        "failed": list(res.report.failed_cameras), "square_measured_mm": res.report.square_measured_mm,
        "opencv_views": opencv.views, "opencv_rms_px": opencv.stereo_rms_px,
        "baseline_mm": diff.baseline_mm, "opencv_baseline_mm": diff.reference_baseline_mm,
        "centre_diff_mm": diff.centre_mm, "rotation_diff_deg": diff.rotation_deg,
        "left_focal_vs_opencv_file_pct": float(100 * (res.rig["left"].matrix_px[0, 0] / sample.matrix_px[0, 0] - 1)),
        "left_pp_vs_opencv_file_px": float(np.abs(res.rig["left"].matrix_px[:2, 2] - sample.matrix_px[:2, 2]).max()),
    }


def _charuco_photo() -> dict | None:
    import cv2
    from gaitcap.acquisition.boards.detection import BoardConfig, make_board
    from gaitcap.acquisition.importers.opencv_samples import read_opencv_camera

    folder = share_path("testdata", "calibration", "opencv-charuco")
    if not (folder / "choriginal.jpg").exists():
        return None
    config = BoardConfig.charuco(5, 7, 40.0, marker_mm=20.0, dictionary="DICT_6X6_250")
    board = make_board(config)
    gray = cv2.imread(str(folder / "choriginal.jpg"), cv2.IMREAD_GRAYSCALE)
    t0 = time.perf_counter()
    found = board.find(gray)
    ms = 1000 * (time.perf_counter() - t0)
    cam = read_opencv_camera(folder / "tutorial_camera_charuco.yml", name="tutorial")
    obj = board.geometry.object_points_mm
    _, rvec, tvec = cv2.solvePnP(obj, found.corners, cam.matrix_px, cam.dist)
    back, _ = cv2.projectPoints(obj, rvec, tvec, cam.matrix_px, cam.dist)
    err = np.linalg.norm(back.reshape(-1, 2) - found.corners, axis=1)
    return {"recording": "OpenCV ChArUco tutorial photo (640x480)", "board": config.describe(),
            "markers": found.n_markers, "corners": found.n_corners, "corners_on_board": board.geometry.num_corners,
            "marker_ratio": found.marker_ratio, "ms": ms, "pnp_rms_px": float(np.sqrt(np.mean(err**2))),
            "pnp_max_px": float(err.max())}


def opencv_samples() -> dict:
    return {"stereo": [r for r in map(_stereo, STEREO_DISTORTIONS) if r is not None], "charuco_photo": _charuco_photo()}


def opencv_lines(r: dict, *, rms_target_px: float, centre_target_mm: float, rotation_target_deg: float) -> list[str]:
    lines = []
    for s in r["stereo"]:
        ok = (not s["failed"] and max(s["rms_px"]) <= rms_target_px and s["centre_diff_mm"] <= centre_target_mm
              and s["rotation_diff_deg"] <= rotation_target_deg)
        lines.append(f"  {s['recording']}, {s['board']}; distortion {s['distortion']}: {s['seconds']:.1f} s, "
                     f"square {s['square_measured_mm']:.2f} mm")
        for k, cam in enumerate(s["cameras"]):
            lines.append(f"    {cam:<8} views {s['views_found'][k]:>3}, used {s['views_used'][k]:>3}, "
                         f"RMS {s['rms_px'][k]:.3f} px")
        lines.append(f"    vs OpenCV's stereoCalibrate of the same images ({s['opencv_views']} views, RMS "
                     f"{s['opencv_rms_px']:.3f} px): baseline {s['baseline_mm']:.2f} vs {s['opencv_baseline_mm']:.2f} mm, "
                     f"right camera's centre {s['centre_diff_mm']:.2f} mm and rotation {s['rotation_diff_deg']:.3f} deg "
                     f"apart; left focal {s['left_focal_vs_opencv_file_pct']:+.2f} %, principal point "
                     f"{s['left_pp_vs_opencv_file_px']:.1f} px from OpenCV's left_intrinsics.yml")
        lines.append(f"    targets (RMS <= {rms_target_px} px, centre <= {centre_target_mm} mm, rotation <= "
                     f"{rotation_target_deg} deg, pair geometry): {'met' if ok else 'NOT met'}")
    p = r["charuco_photo"]
    if p:
        lines.append(f"  {p['recording']}, {p['board']}: {p['markers']} markers, {p['corners']} of "
                     f"{p['corners_on_board']} corners ({p['ms']:.0f} ms), marker/square {p['marker_ratio']:.3f}; "
                     f"with its camera's calibration one board pose reprojects to {p['pnp_rms_px']:.3f} px RMS "
                     f"(max {p['pnp_max_px']:.3f} px)")
    return lines
