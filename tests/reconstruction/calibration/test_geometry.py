import cv2
import numpy as np
import pytest
from gaitcap.reconstruction.calibration.geometry import (
    BoardObservations,
    grid_board,
    mean_rotation,
    rodrigues_batch,
    rotation_angle_deg,
)


def test_grid_board_layout_and_symmetries():
    b = grid_board("b", corners_x=4, corners_y=3, square_mm=50.0, mirror_ambiguous=True, min_corners=12)
    assert b.num_corners == 12
    assert np.allclose(b.object_points_mm[5], [50.0, 50.0, 0.0])  # row 1, column 1
    assert len(b.symmetries) == 4
    d = np.linalg.norm(b.object_points_mm[b.neighbours[:, 0]] - b.object_points_mm[b.neighbours[:, 1]], axis=1)
    assert np.allclose(d, 50.0) and len(d) == 3 * 3 + 4 * 2
    rot180 = np.asarray(b.symmetries[1])
    centre = b.object_points_mm.mean(0)
    assert np.allclose(b.object_points_mm[rot180] - centre, -(b.object_points_mm - centre))


def test_square_ambiguous_grid_is_refused():
    with pytest.raises(ValueError, match="square corner grid"):
        grid_board("b", corners_x=4, corners_y=4, square_mm=50.0, mirror_ambiguous=True, min_corners=16)


def test_observations_wrong_board_size_named():
    b = grid_board("small", corners_x=3, corners_y=2, square_mm=50.0, mirror_ambiguous=False, min_corners=6)
    with pytest.raises(ValueError, match="wrong board size"):
        BoardObservations(("a",), ((640, 480),), np.zeros((1, 2, 8, 2)), b)


def test_rotation_helpers_match_opencv():
    rng = np.random.default_rng(1)
    rv = rng.normal(0, 1, (20, 3))
    mats = rodrigues_batch(rv)
    assert np.allclose(mats[3], cv2.Rodrigues(rv[3])[0], atol=1e-12)
    assert np.allclose(rotation_angle_deg(mats[0], mats[0]), 0, atol=1e-5)
    small = rodrigues_batch(np.array([[0.0, 0.0, np.radians(1.0)], [0.0, 0.0, -np.radians(1.0)]]))
    assert np.allclose(mean_rotation(small), np.eye(3), atol=1e-12)
