"""ChArUco detection on a real photo: OpenCV's ChArUco tutorial image of a printed 5 x 7 board
(DICT_6X6_250, markers half a square; 640x480) and the calibration of its camera, from Debian's
opencv-doc (installed by deploy/bootstrap.sh). The printing variants and partial views are the same real
pixels turned, inverted or cut; the readers' errors name what is wrong."""

import cv2
import numpy as np
import pytest
from gaitcap.acquisition.boards.detection import BoardConfig, make_board
from gaitcap.acquisition.importers.opencv_samples import read_opencv_camera
from gaitcap.acquisition.installed import share_path
from gaitcap.reconstruction.calibration.compare import stereo_difference
from gaitcap.reconstruction.camera import Camera, Rig

PHOTO = share_path("testdata", "calibration", "opencv-charuco")
BOARD = BoardConfig.charuco(5, 7, 40.0, marker_mm=20.0, dictionary="DICT_6X6_250")  # the tutorial's board
needs_photo = pytest.mark.skipif(not (PHOTO / "choriginal.jpg").exists(),
                                 reason=f"OpenCV's ChArUco photo not installed in {PHOTO} (run deploy/bootstrap.sh)")


@pytest.fixture(scope="module")
def photo():
    gray = cv2.imread(str(PHOTO / "choriginal.jpg"), cv2.IMREAD_GRAYSCALE)
    return gray, make_board(BOARD).find(gray)


@needs_photo
def test_the_whole_board_is_found_and_fits_its_cameras_calibration(photo):
    gray, found = photo
    # all 17 markers and all 4 x 6 inner corners are in view, sharp and unoccluded in this photo
    assert (found.n_markers, found.n_corners) == (17, 24)
    assert not found.variant.inverted and not found.variant.mirrored
    assert abs(found.marker_ratio - 0.5) < 0.05  # measured 0.476 from the markers alone (printed 0.5)
    # the camera's own calibration (OpenCV's file): one board pose reprojects every corner; the calibration
    # itself reprojected to 0.18 px on average, and this view measures 0.22 px RMS (max 0.41 px)
    cam = read_opencv_camera(PHOTO / "tutorial_camera_charuco.yml", name="tutorial")
    assert cam.size_px == gray.shape[::-1]
    obj = make_board(BOARD).geometry.object_points_mm
    ok, rvec, tvec = cv2.solvePnP(obj, found.corners, cam.matrix_px, cam.dist)
    back, _ = cv2.projectPoints(obj, rvec, tvec, cam.matrix_px, cam.dist)
    err = np.linalg.norm(back.reshape(-1, 2) - found.corners, axis=1)
    assert ok and np.sqrt(np.mean(err**2)) < 0.3 and err.max() < 0.6


@needs_photo
@pytest.mark.parametrize("variant", ["inverted", "mirrored"])
def test_a_board_printed_otherwise_is_found_in_the_same_real_pixels(photo, variant):
    gray, found = photo
    image = 255 - gray if variant == "inverted" else cv2.flip(gray, 1)  # mirrored: a two-sided board's back
    again = make_board(BOARD).find(image)
    assert again.n_corners == 24 and getattr(again.variant, variant)
    expected = found.corners.copy()
    if variant == "mirrored":
        expected[:, 0] = gray.shape[1] - 1 - expected[:, 0]  # back in the camera's image
    np.testing.assert_allclose(again.corners, expected, atol=0.01)


@needs_photo
def test_a_partial_view_keeps_the_corners_it_sees(photo):
    gray, found = photo
    cut = make_board(BOARD).find(gray[:240])  # the image's upper half: the board's far rows only
    seen = np.flatnonzero(np.isfinite(cut.corners[:, 0]))
    # corners 0-10 (the board's first rows and one more) keep markers on both sides; measured 11 of 24
    assert seen.tolist() == list(range(11))
    np.testing.assert_allclose(cut.corners[seen], found.corners[seen], atol=0.01)
    assert make_board(BOARD).find(gray[:160]).corners is None  # 3 corners: too few to count as a view


def test_an_opencv_file_without_the_camera_matrix_names_the_field(tmp_path):
    path = tmp_path / "calib.yml"
    path.write_text("%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\n")
    with pytest.raises(ValueError, match="'camera_matrix' is missing"):
        read_opencv_camera(path, name="c")
    with pytest.raises(ValueError, match="does not exist"):
        read_opencv_camera(tmp_path / "none.yml", name="c")


def test_stereo_difference_measures_the_pair_in_its_own_frame():
    k = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])
    left, right = Camera("l", (640, 480), k), Camera("r", (640, 480), k, tvec_mm=np.array([-100.0, 0, 0]))
    moved = np.array([0.0, 0.3, 0.0])  # the pair turned and shifted into another world frame, 2 mm wider
    other = Rig((left.replace(rvec=moved, tvec_mm=np.array([5.0, 6, 7])),
                 right.replace(rvec=moved, tvec_mm=np.array([5.0 - 102, 6, 7]))))
    diff = stereo_difference(Rig((left, right)), other, first="l", second="r")
    assert diff.reference_baseline_mm == pytest.approx(100.0) and diff.baseline_mm == pytest.approx(102.0)
    assert diff.centre_mm == pytest.approx(2.0) and diff.rotation_deg == pytest.approx(0.0, abs=1e-6)
    with pytest.raises(ValueError, match="no camera"):
        stereo_difference(Rig((left, right)), Rig((left,)), first="l", second="r")
