import cv2
import jax.numpy as jnp
import numpy as np
from gaitcap.reconstruction.camera import Camera, Rig
from gaitcap.reconstruction.projection import camera_arrays, distort, project_points, undistort_pixels
from hypothesis import given, settings
from hypothesis import strategies as st


def _rig(dist, skew=0.0) -> Rig:
    k = np.array([[1400.0, skew, 960], [0, 1390.0, 600], [0, 0, 1]])
    cams = (
        Camera("a", (1920, 1200), k, np.array(dist), np.array([0.3, -0.5, 0.1]), np.array([100.0, -200, 4000])),
        Camera("b", (1920, 1200), k * [[0.8], [0.8], [1]], np.array(dist) * 0.5, np.array([-0.2, 0.4, 0.0]),
               np.array([-300.0, 50, 3500])),
    )
    return Rig(cams)


DIST = (-0.2, 0.05, 0.001, -0.002, 0.01)


def test_projection_matches_opencv():
    rig = _rig(DIST)
    pts = np.random.default_rng(0).uniform(-1000, 1000, size=(4, 50, 3))
    ours = np.asarray(project_points(pts, camera_arrays(rig)))
    assert ours.shape == (2, 4, 50, 2)
    for c, cam in enumerate(rig):
        ref, _ = cv2.projectPoints(pts.reshape(-1, 3), cam.rvec, cam.tvec_mm, cam.matrix_px, cam.dist)
        assert np.abs(ours[c].reshape(-1, 2) - ref[:, 0]).max() < 2e-3  # float32


def test_undistortion_matches_opencv():
    rig = _rig(DIST)  # OpenCV's undistortPoints ignores skew
    cams = camera_arrays(rig)
    rng = np.random.default_rng(1)
    px = rng.uniform([100, 100], [1820, 1100], size=(2, 300, 2))
    xn, yn = undistort_pixels(jnp.asarray(px[..., 0]), jnp.asarray(px[..., 1]), cams)
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    for c, cam in enumerate(rig):
        ref = cv2.undistortPoints(px[c][:, None], cam.matrix_px, cam.dist, criteria=crit)[:, 0]
        assert np.abs(np.asarray(xn[c]) - ref[:, 0]).max() < 1e-5
        assert np.abs(np.asarray(yn[c]) - ref[:, 1]).max() < 1e-5


@settings(max_examples=40, deadline=None)
@given(
    k1=st.floats(-0.3, 0.3), k2=st.floats(-0.05, 0.05), p1=st.floats(-0.002, 0.002),
    p2=st.floats(-0.002, 0.002), x=st.floats(-0.5, 0.5), y=st.floats(-0.4, 0.4),
)
def test_undistort_inverts_distort(k1, k2, p1, p2, x, y):
    dist = jnp.asarray([[k1, k2, p1, p2, 0.0]], jnp.float32)
    xd, yd = distort(jnp.asarray([[x]]), jnp.asarray([[y]]), dist)
    rig = Rig((Camera("a", (100, 100), np.eye(3), np.array([k1, k2, p1, p2, 0.0])),))
    xu, yu = undistort_pixels(xd, yd, camera_arrays(rig))  # K = I: pixels are normalised coordinates
    assert abs(float(xu[0, 0]) - x) < 1e-4 and abs(float(yu[0, 0]) - y) < 1e-4


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-800, 800), min_size=3, max_size=3))
def test_jax_projection_matches_numpy_model(p):
    rig = _rig(DIST, skew=1.5)  # OpenCV's projectPoints ignores skew; the NumPy model does not
    ours = np.asarray(project_points(np.array([p]), camera_arrays(rig)))[:, 0]
    ref = rig.project(np.array(p))
    assert np.abs(ours - ref).max() < 2e-3
