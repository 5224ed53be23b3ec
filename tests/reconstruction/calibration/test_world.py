import numpy as np
from gaitcap.reconstruction.calibration.geometry import rodrigues_batch
from gaitcap.reconstruction.calibration.world import WorldFrameConfig, floor_pose, to_world, world_from_floor


def test_floor_board_defines_z_up_and_origin():
    floor_r = rodrigues_batch(np.array([0.3, -0.2, 0.1]))  # board -> old frame
    floor_t = np.array([100.0, -50.0, 3000.0])
    up = floor_r @ np.array([0.0, 0.0, -1.0])  # out of the printed face
    centres = floor_t + 2500.0 * up + np.array([[1000.0, 0, 0], [0, 1500, 0], [-900, 200, 0]])
    cam_r = np.tile(np.eye(3), (3, 1, 1))
    world = world_from_floor(floor_r, floor_t, cam_r, -centres)
    assert not world.flipped
    r, t = to_world(world, cam_r, -centres)
    centres_w = -np.einsum("cji,cj->ci", r, t)
    assert np.all(centres_w[:, 2] > 2000)
    assert np.allclose(world.tvec_mm, floor_t)  # corner 0 is the origin


def test_cameras_below_the_floor_turn_the_world_over():
    floor_r, floor_t = np.diag([1.0, -1.0, -1.0]), np.zeros(3)  # face up in the old frame
    centres = np.array([[0.0, 0, -2000], [500, 0, -2500]])  # ... yet the cameras are below it
    cam_r = np.tile(np.eye(3), (2, 1, 1))
    world = world_from_floor(floor_r, floor_t, cam_r, -centres)
    assert world.flipped
    r, t = to_world(world, cam_r, -centres)
    assert np.all(-np.einsum("cji,cj->ci", r, t)[:, 2] > 0)


def test_static_floor_frames_are_averaged():
    n = 8
    rot = np.tile(np.eye(3), (n, 1, 1))
    tvec = np.zeros((n, 3))
    tvec[:5] += np.random.default_rng(0).normal(0, 0.3, (5, 3))
    tvec[5:] += [0.0, 0.0, 400.0]  # picked up
    used = np.ones(n, dtype=bool)
    _, t, frames = floor_pose(rot, tvec, used, WorldFrameConfig())
    assert frames == 5 and np.allclose(t, tvec[:5].mean(0))


def test_board_laid_down_elsewhere_sets_the_floor_tilt():
    from gaitcap.reconstruction.calibration.world import floor_plane

    obj = np.column_stack([np.mgrid[0:6, 0:4].reshape(2, -1).T * 110.0, np.zeros(24)])
    face_up = np.diag([1.0, -1.0, -1.0])
    tilted = rodrigues_batch(np.array([np.radians(0.3), 0.0, 0.0])) @ face_up  # first pose, slightly off
    spots = np.array([[0.0, 0, 0], [2000, 1500, 0], [-1800, 1200, 0], [1500, -2000, 0]])
    rot = np.stack([tilted, face_up, face_up, face_up])
    used = np.ones(4, dtype=bool)
    r, t, n = floor_plane(tilted, spots[0], rot, spots, used, obj, WorldFrameConfig())
    assert n == 4
    assert np.degrees(np.arccos(np.clip(r[:, 2] @ [0, 0, -1.0], -1, 1))) < 0.05
    assert abs(t[2]) < 1.0
