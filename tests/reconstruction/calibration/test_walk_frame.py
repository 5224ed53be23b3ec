import numpy as np
import pytest
from gaitcap.reconstruction.calibration.geometry import rodrigues_batch, rotation_angle_deg
from gaitcap.reconstruction.calibration.walk_frame import reframe_rig, world_from_walk
from gaitcap.reconstruction.camera import Camera, Rig, matrix_to_rodrigues
from gaitcap.simulator import make_trial

FEET = ["left_heel", "right_heel", "left_big_toe", "right_big_toe"]


@pytest.fixture(scope="module")
def walk():
    trial = make_trial(preset="clean", seconds=6.0, cameras=4, seed=2)
    sk = trial.skeleton
    feet = trial.points_mm[:, [sk.index(n) for n in FEET]]
    return feet, trial.points_mm[:, sk.index("pelvis")]


def test_floor_and_walking_direction_from_the_feet(walk):
    feet, pelvis = walk
    g_rot = rodrigues_batch(np.array([0.4, -0.3, 1.2]))  # an arbitrary calibration frame
    g_t = np.array([500.0, -2000.0, 3000.0])
    world = world_from_walk(feet @ g_rot.T + g_t, pelvis @ g_rot.T + g_t, foot_height_mm=19.0)
    z_true = g_rot @ [0.0, 0.0, 1.0]
    assert np.degrees(np.arccos(np.clip(world.rotation[:, 2] @ z_true, -1, 1))) < 0.5
    walk_dir = pelvis[-1] - pelvis[0]
    walk_dir = g_rot @ (walk_dir * [1, 1, 0]) / np.linalg.norm(walk_dir[:2])
    assert world.rotation[:, 0] @ walk_dir > 0.98
    feet_world = (feet @ g_rot.T + g_t - world.tvec_mm) @ world.rotation
    assert np.nanstd(feet_world[..., 2] - feet[..., 2]) < 2.0  # the same floor plane
    assert abs(np.nanmedian(feet_world[..., 2] - feet[..., 2])) < 5.0  # heels 21 mm, toes 17.5 mm above it


def test_reframe_rig_keeps_projections():
    cam = Camera("c", (640, 480), np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]]),
                 rvec=matrix_to_rodrigues(rodrigues_batch(np.array([0.1, 0.2, 0.3]))), tvec_mm=[10.0, 20, 3000])
    from gaitcap.reconstruction.calibration.world import WorldTransform

    world = WorldTransform(rodrigues_batch(np.array([0.0, 0.5, 0.2])), np.array([100.0, 0, 50]), 0, False)
    moved = reframe_rig(Rig((cam,)), world)
    pts_world = np.random.default_rng(0).uniform(-300, 300, (5, 3))
    pts_old = pts_world @ world.rotation.T + world.tvec_mm
    assert np.allclose(moved["c"].project(pts_world), cam.project(pts_old))
    assert rotation_angle_deg(moved["c"].rotation, cam.rotation @ world.rotation) < 1e-6


def test_missing_pelvis_is_an_error(walk):
    feet, pelvis = walk
    with pytest.raises(ValueError, match="pelvis"):
        world_from_walk(feet, np.full_like(pelvis, np.nan))
