import cv2
import numpy as np
import pytest
from gaitcap.reconstruction.camera import Camera, Rig, matrix_to_rodrigues, rodrigues_to_matrix
from hypothesis import given, settings
from hypothesis import strategies as st


def _camera(dist=(-0.2, 0.05, 0.001, -0.002, 0.01)) -> Camera:
    k = np.array([[1400.0, 0, 960], [0, 1390.0, 600], [0, 0, 1]])
    return Camera("c0", (1920, 1200), k, np.array(dist), np.array([0.3, -0.5, 0.1]), np.array([100.0, -200, 4000]))


def test_projection_matches_opencv():
    cam = _camera()
    rng = np.random.default_rng(0)
    pts = rng.uniform(-1000, 1000, size=(200, 3))
    ours = cam.project(pts)
    ref, _ = cv2.projectPoints(pts, cam.rvec, cam.tvec_mm, cam.matrix_px, cam.dist)
    assert np.abs(ours - ref[:, 0]).max() <= 1e-6


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3))
def test_rodrigues_matches_opencv_and_round_trips(rv):
    rv = np.array(rv)
    rmat = rodrigues_to_matrix(rv)
    ref, _ = cv2.Rodrigues(rv)
    assert np.allclose(rmat, ref, atol=1e-9)
    assert np.allclose(rodrigues_to_matrix(matrix_to_rodrigues(rmat)), rmat, atol=1e-7)


def test_center_is_projection_centre():
    cam = _camera()
    assert np.allclose(cam.to_camera(cam.center_mm), 0, atol=1e-9)


def test_bad_fields_are_named():
    with pytest.raises(ValueError, match="camera 'x' matrix_px"):
        Camera("x", (10, 10), np.eye(2))
    with pytest.raises(ValueError, match="tvec_mm"):
        Camera("x", (10, 10), np.eye(3), tvec_mm=[np.nan, 0, 0])
    with pytest.raises(ValueError, match="size_px"):
        Camera("x", (0, 10), np.eye(3))


def test_rig_names_and_lookup():
    rig = Rig((_camera(), _camera().replace(name="c1")))
    assert rig.names == ["c0", "c1"]
    assert rig["c1"].name == "c1"
    with pytest.raises(ValueError, match="duplicate"):
        Rig((_camera(), _camera()))
    with pytest.raises(ValueError, match=r"\['zz'\]"):
        rig.index_of(["c0", "zz"])
    assert rig.project(np.zeros((4, 3))).shape == (2, 4, 2)
