"""OpenCV's own sample recordings and OpenCV's calibrations of them, for comparing gaitcap's calibration
with another tool's on the same real images.

- ``read_opencv_camera``: one camera from an OpenCV calibration file (``cv::FileStorage`` YAML/XML as the
  ``calibration`` sample and the ArUco tutorials write it: ``camera_matrix``, ``distortion_coefficients``,
  ``image_width``/``image_height``).
- ``opencv_stereo_calibration``: OpenCV's own two-camera calibration of synchronised checkerboard images
  (``findChessboardCorners`` + ``cornerSubPix``, ``calibrateCamera`` per camera, then ``stereoCalibrate``
  refining both together), the reference for the stereo sample (OpenCV ships no stereo result).

The pair's two calibrations are compared with :func:`gaitcap.reconstruction.calibration.compare.stereo_difference`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from gaitcap.acquisition.boards.detection import BoardConfig
from gaitcap.reconstruction.camera import Camera, Rig, matrix_to_rodrigues

SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)


def _matrix(fs: cv2.FileStorage, key: str, where: str) -> np.ndarray:
    node = fs.getNode(key)
    if node.empty():
        raise ValueError(f"{where}: field {key!r} is missing")
    return np.asarray(node.mat(), dtype=np.float64)


def read_opencv_camera(path: str | os.PathLike, *, name: str, size_px: tuple[int, int] | None = None) -> Camera:
    """The intrinsics (K px, distortion) in an OpenCV calibration file, as a camera at the world origin.
    ``size_px`` (width, height) is needed when the file holds no ``image_width``/``image_height``."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"OpenCV calibration {str(path)!r} does not exist")
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    try:
        where = str(path)
        matrix = _matrix(fs, "camera_matrix", where)
        dist = _matrix(fs, "distortion_coefficients", where).reshape(-1)
        width, height = fs.getNode("image_width"), fs.getNode("image_height")
        if not (width.empty() or height.empty()):
            size_px = (int(width.real()), int(height.real()))
        if size_px is None:
            raise ValueError(f"{where}: no image_width/image_height; give size_px")
    finally:
        fs.release()
    if dist.size > 5 and np.any(dist[5:] != 0):
        raise ValueError(f"{path}: {dist.size} distortion terms (rational/thin-prism model); only k1 k2 p1 p2 k3")
    return Camera(name, size_px, matrix, dist[:5])


def _find_corners(path: Path, pattern: tuple[int, int]) -> np.ndarray | None:
    gray = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if gray is None:
        raise ValueError(f"{path}: not an image")
    ok, corners = cv2.findChessboardCorners(gray, pattern)
    if not ok:
        return None
    return cv2.cornerSubPix(gray, corners, (11, 11), (-1, -1), SUBPIX_CRITERIA)


@dataclass(frozen=True)
class OpenCVStereo:
    """OpenCV's calibration of a camera pair: the rig (world = the first camera, mm), the views it used
    (both cameras found the board) and its RMS reprojection error (px) per camera alone and together."""

    rig: Rig
    views: int
    mono_rms_px: tuple[float, float]
    stereo_rms_px: float


def opencv_stereo_calibration(first: list[Path], second: list[Path], *, board: BoardConfig,
                              names: tuple[str, str] = ("left", "right")) -> OpenCVStereo:
    """OpenCV's own calibration of two cameras from synchronised checkerboard images (``first[k]`` and
    ``second[k]`` taken at once); 5 distortion terms per camera."""
    if board.kind != "checkerboard":
        raise ValueError(f"opencv_stereo_calibration: a checkerboard is needed, got {board.kind}")
    if len(first) != len(second) or not first:
        raise ValueError(f"opencv_stereo_calibration: {len(first)} {names[0]} and {len(second)} {names[1]} images; "
                         "the same number (> 0) is needed")
    pattern = (board.squares_x - 1, board.squares_y - 1)
    grid = np.zeros((pattern[0] * pattern[1], 3), np.float32)
    grid[:, :2] = np.mgrid[0:pattern[0], 0:pattern[1]].T.reshape(-1, 2) * board.square_mm
    pairs = [(a, b) for a, b in ((_find_corners(p, pattern), _find_corners(q, pattern))
                                 for p, q in zip(first, second, strict=True)) if a is not None and b is not None]
    if len(pairs) < 3:
        raise ValueError(f"opencv_stereo_calibration: the board is found in both cameras in {len(pairs)} image "
                         "pairs; 3 are needed")
    size = cv2.imread(str(first[0]), cv2.IMREAD_GRAYSCALE).shape[::-1]
    obj = [grid] * len(pairs)
    mono = [cv2.calibrateCamera(obj, [p[k] for p in pairs], size, None, None) for k in (0, 1)]
    rms, k1, d1, k2, d2, rot, trans, _, _ = cv2.stereoCalibrate(
        obj, [p[0] for p in pairs], [p[1] for p in pairs], mono[0][1], mono[0][2], mono[1][1], mono[1][2], size,
        flags=cv2.CALIB_USE_INTRINSIC_GUESS, criteria=(cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 200, 1e-9))
    rig = Rig((Camera(names[0], size, k1, d1.ravel()[:5]),
               Camera(names[1], size, k2, d2.ravel()[:5], matrix_to_rodrigues(rot), trans.ravel())))
    return OpenCVStereo(rig, len(pairs), (float(mono[0][0]), float(mono[1][0])), float(rms))
