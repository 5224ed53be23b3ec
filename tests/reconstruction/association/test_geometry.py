import numpy as np
from gaitcap.reconstruction.association.geometry import (
    pixel_rays,
    triangulate_rays,
    two_ray_closest,
    undistort_normalized,
)
from gaitcap.reconstruction.camera import Camera


def test_undistort_inverts_opencv_distortion():
    cam = Camera("a", (100, 100), np.eye(3), dist=np.array([-0.2, 0.05, 0.001, -0.002, 0.01]))
    xy = np.random.default_rng(0).uniform(-0.5, 0.5, (200, 2))
    back = undistort_normalized(cam.distort_normalized(xy), cam.dist)
    assert np.abs(back - xy).max() < 1e-6


def test_rays_pass_through_the_projected_points(scene3):
    rig = scene3.rig
    pts = scene3.points_mm[0, :5]  # (T, J, 3)
    origins, dirs = pixel_rays(rig, rig.project(pts))
    rel = pts[None] - origins[:, None, None, :]
    along = (rel * dirs).sum(-1, keepdims=True)
    off_ray = np.linalg.norm(rel - along * dirs, axis=-1)
    assert off_ray.max() < 1e-3 and along.min() > 0


def test_two_ray_closest_matches_direct_geometry():
    rng = np.random.default_rng(1)
    o1, o2 = rng.normal(0, 1000, 3), rng.normal(0, 1000, 3)
    d1, d2 = (v / np.linalg.norm(v) for v in rng.normal(size=(2, 3)))
    w = o1 - o2
    s, u, gap = two_ray_closest(w @ w, d1 @ w, d2 @ w, d1 @ d2)
    p1, p2 = o1 + s * d1, o2 + u * d2
    assert np.isclose(np.linalg.norm(p1 - p2), gap)
    # the connecting segment is perpendicular to both rays
    assert abs((p1 - p2) @ d1) < 1e-6 and abs((p1 - p2) @ d2) < 1e-6


def test_triangulate_rays_recovers_points_and_flags_single_views(scene3):
    rig = scene3.rig
    pts = scene3.points_mm[1, :4]  # (T, J, 3)
    origins, dirs = pixel_rays(rig, rig.project(pts))  # dirs (C, T, J, 3)
    weights = np.ones((4, 1, len(rig), pts.shape[1]))
    got, wsum = triangulate_rays(origins, dirs.transpose(1, 0, 2, 3), weights)
    assert np.abs(got[:, 0] - pts).max() < 1e-3
    assert np.all(wsum == len(rig))
    weights[:, :, 1:] = 0  # one view only: no point
    got, _ = triangulate_rays(origins, dirs.transpose(1, 0, 2, 3), weights)
    assert np.isnan(got).all()
