"""The board's motion in a calibration: cameras exposed at different instants (webcams are not
synchronised) have their time offsets adjusted from the board's motion, bringing the rig back to the
truth; views where the board moved fast weigh less, by a noise model fitted to the residuals; a clip
whose views are too far apart in time says the motion was not modelled."""

import numpy as np
import pytest
from gaitcap.acquisition.boards.detection import BoardConfig, make_board
from gaitcap.reconstruction.calibration import (
    BoardObservations,
    CalibrationConfig,
    calibrate_from_observations,
)
from gaitcap.reconstruction.calibration.compare import compare_similar
from gaitcap.reconstruction.calibration.motion import (
    MotionConfig,
    corner_velocities,
    motion_report,
    speed_weights,
)
from gaitcap.simulator.board import BoardMotion, board_trajectory, observe_board
from gaitcap.simulator.room import build_rig
from scipy.spatial.transform import Rotation, Slerp

FPS = 30.0
OFFSETS_S = (0.0, 0.010, -0.008)


def _at(rot, tvec, shift_frames: float):
    """The board's poses ``shift_frames`` frame intervals later (interpolated; the ends held)."""
    n = len(rot)
    times = np.clip(np.arange(n) + shift_frames, 0, n - 1)
    lo = np.floor(times).astype(int)
    hi = np.minimum(lo + 1, n - 1)
    t = tvec[lo] + (times - lo)[:, None] * (tvec[hi] - tvec[lo])
    return Slerp(np.arange(n), Rotation.from_matrix(rot))(times).as_matrix(), t


@pytest.fixture(scope="module")
def offset_rig():
    """Three cameras of the synthetic room sharing views of a board waved at 30 fps, the second exposed
    10 ms and the third -8 ms after the first."""
    rig = build_rig(10, seed=0).subset(["cam01", "cam02", "cam03"])
    board = make_board(BoardConfig.checkerboard()).geometry
    motion = BoardMotion(n_frames=100, floor_frames=3, fps=FPS, tour_fraction=0.0,
                         half_extent_mm=(1200.0, 1200.0, 300.0), seed=1)
    rot, tvec = board_trajectory(board, motion, rig)
    corners = []
    for c, cam in enumerate(rig):
        r, t = _at(rot, tvec, OFFSETS_S[c] * FPS)
        corners.append(observe_board(rig.subset([cam.name]), board, r, t, noise_px=0.2, fps=FPS,
                                     seed=2 + c).corners_px[0])
    obs = BoardObservations(tuple(rig.names), tuple(c.size_px for c in rig), np.stack(corners), board,
                            np.arange(len(rot)) / FPS)
    return rig, obs


def test_time_offsets_are_adjusted_from_the_board_motion(offset_rig):
    rig, obs = offset_rig
    assert (obs.views().sum(0) >= 2).sum() >= 25  # the cameras share views
    moved = calibrate_from_observations(obs, config=CalibrationConfig(motion=MotionConfig()))
    still = calibrate_from_observations(obs)
    m = moved.report.motion
    assert m["root"] == "cam01" and m["offsets_ms"][0] == 0.0
    found = np.array(m["offsets_ms"][1:])
    assert np.all(np.abs(found - [10.0, -8.0]) < 1.0), found  # measured: 10.0, -8.3
    assert max(m["offsets_se_ms"]) < 0.5
    assert m["notes"][-1].startswith("time offsets from the board's motion, after cam01: cam02 +10.0 +- "), m["notes"]
    err_moved, err_still = (compare_similar(rig, r.rig) for r in (moved, still))
    assert err_moved.rotation_deg_max < 0.7 * err_still.rotation_deg_max, (err_moved, err_still)
    assert moved.report.reprojection_rms_px < 0.8 * still.report.reprojection_rms_px
    assert still.report.motion == {}


def test_fast_views_weigh_less_by_a_noise_model_fitted_to_the_residuals():
    rng = np.random.default_rng(0)
    views, per_view = 60, 40
    cam = np.repeat(np.arange(views) % 2, per_view)
    frame = np.repeat(np.arange(views), per_view)
    speed = np.repeat(rng.uniform(0, 400, views), per_view)  # px/s
    vel = np.stack([speed, np.zeros_like(speed)], 1)
    sigma = np.sqrt(0.3**2 + (0.004 * speed) ** 2 / 2)  # per axis: 0.3 px at rest, a 4 ms smear
    err = rng.normal(0, 1, (len(cam), 2)) * sigma[:, None]
    w = speed_weights(cam=cam, frame=frame, residual_px=err, inlier=np.ones(len(cam), bool), velocity_px_s=vel,
                      config=MotionConfig())
    assert abs(w.sigma0_px - 0.3) < 0.05 and abs(1e3 * w.smear_s - 4.0) < 1.0, w
    fast, slow = speed > 300, speed < 20
    assert w.weight[fast].max() < 0.4 < 0.9 < w.weight[slow].min()
    flat = speed_weights(cam=cam, frame=frame, residual_px=rng.normal(0, 0.3, err.shape), inlier=np.ones(len(cam), bool),
                         velocity_px_s=vel, config=MotionConfig())
    assert np.all(flat.weight == 1.0)  # errors that do not grow with speed: every view the same
    report = motion_report(("a", "b"), 0, None, np.zeros(0), flat, MotionConfig())
    assert report.notes == ("the board's speed did not raise the views' errors: every view weighs the same",)


def test_views_too_far_apart_in_time_leave_the_motion_unmodelled(offset_rig):
    _, obs = offset_rig
    sparse = BoardObservations(obs.camera_names, obs.image_sizes_px, obs.corners_px, obs.board, obs.times_s * 10)
    vel = corner_velocities(sparse, 0.25)
    assert np.isnan(vel).all() and np.isfinite(corner_velocities(obs, 0.25)).all(-1).sum() > 0.9 * obs.seen().sum()
    rows = np.nonzero(obs.seen())
    w = speed_weights(cam=rows[0], frame=rows[1], residual_px=np.zeros((len(rows[0]), 2)),
                      inlier=np.ones(len(rows[0]), bool), velocity_px_s=vel[rows], config=MotionConfig())
    report = motion_report(obs.camera_names, 0, None, np.zeros(0), w, MotionConfig(), "time offsets not adjusted")
    assert report.notes[0] == ("the board's motion not modelled: 0 views have a neighbouring view of their camera "
                               "within 250 ms (need 10)") and np.all(w.weight == 1.0)
