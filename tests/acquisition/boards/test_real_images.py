"""Board detection on real webcam frames: a hand-held 10 x 7 checkerboard filmed by caliscope's four
1280x720 webcams (frames from the caliscope 0.7.5 sdist, installed by deploy/bootstrap.sh)."""

import cv2
import numpy as np
import pytest
from gaitcap.acquisition.boards.detection import BoardConfig, make_board
from gaitcap.acquisition.installed import share_path

FRAMES = share_path("testdata", "calibration", "caliscope-chessboard")
pytestmark = pytest.mark.skipif(not (FRAMES / "cam_0_frame_1070.jpg").exists(),
                                reason=f"caliscope checkerboard frames not installed in {FRAMES} (run deploy/bootstrap.sh)")


def test_the_board_is_found_in_real_frames_and_only_when_whole():
    board = make_board(BoardConfig.checkerboard(10, 7, 25.0))
    for cam in (0, 3):  # two of the four cameras: real-size frames are slow to search on 2 cores
        gray = cv2.imread(str(FRAMES / f"cam_{cam}_frame_1070.jpg"), cv2.IMREAD_GRAYSCALE)
        corners = board.detect(gray)
        assert corners is not None and corners.shape == (54, 2), f"cam_{cam}"
        # a real lens bends the grid a little, but the corners still lie on one projective grid
        obj = board.geometry.object_points_mm[:, :2]
        hom, _ = cv2.findHomography(obj, corners)
        resid = np.linalg.norm(cv2.perspectiveTransform(obj.reshape(-1, 1, 2), hom).reshape(-1, 2) - corners, axis=1)
        assert np.median(resid) < 2.0 and resid.max() < 4.0, f"cam_{cam}: {np.median(resid):.2f} px"
    cut = cv2.imread(str(FRAMES / "cam_0_frame_000.jpg"), cv2.IMREAD_GRAYSCALE)  # board half out of the image
    assert board.detect(cut) is None


POSE2SIM = FRAMES.parent / "pose2sim-single" / "calibration"


@pytest.mark.skipif(not (POSE2SIM / "Calib.qca.txt").exists(), reason=f"Pose2Sim demo not installed in {POSE2SIM}")
def test_intrinsics_from_real_views_agree_with_qualisys():
    """Pose2Sim's demo camera 2 (1088x1920): the board found in hand-held views (the 5th turned in the
    image: found by the exhaustive search only), and the focal length from them within 1 % of
    Qualisys's calibration of the same camera."""
    from gaitcap.acquisition.importers.tool_folders import read_qca
    from gaitcap.reconstruction.calibration import BoardObservations, IntrinsicsConfig
    from gaitcap.reconstruction.calibration.intrinsics import estimate_intrinsics

    board = make_board(BoardConfig.checkerboard(8, 5, 60.0))  # Pose2Sim's Config.toml: 4 x 7 inner corners
    views = [board.detect(cv2.imread(str(POSE2SIM / "intrinsics" / "int_cam02_img" / f"cam02_0{k}_int.jpg"),
                                     cv2.IMREAD_GRAYSCALE)) for k in (1, 2, 5, 7)]
    assert all(v is not None for v in views)
    obs = BoardObservations(("cam02",), ((1088, 1920),), np.stack(views)[None], board.geometry)
    intr = estimate_intrinsics(obs, 0, IntrinsicsConfig(min_views=3, min_tilted_views=2))
    reference = read_qca(POSE2SIM / "Calib.qca.txt")["cam02"].matrix_px[0, 0]
    assert abs(intr.matrix_px[0, 0] / reference - 1) < 0.01 and intr.rms_px < 0.3
