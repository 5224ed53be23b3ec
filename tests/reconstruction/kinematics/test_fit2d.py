"""Joint angles fitted directly to 2D keypoints: the chain's conventions reproduce the walker's angles, and
a fit to its detections from a noisy start recovers them (bench/kinematics_2d.py measures a 30 s trial)."""

import numpy as np
import pytest
from gaitcap.reconstruction.kinematics.fit2d import (
    JOINTS,
    Fit2DConfig,
    chain_points,
    fit_angles_2d,
    initial_params,
)
from gaitcap.reconstruction.kinematics.geometric import keypoint_angles


@pytest.fixture(scope="module")
def trial():
    from gaitcap.simulator.trial import make_trial

    return make_trial("clean", seconds=4.0, cameras=3, seed=1)


def _rmse(a: dict, b: dict, var: str) -> float:
    d = np.concatenate([a[var][s] - b[var][s] for s in ("left", "right")])
    return float(np.sqrt(np.nanmean(d**2)))


def test_chain_started_from_exact_keypoints_has_their_angles(trial):
    names = list(trial.skeleton.joint_names)
    pts = np.asarray(chain_points(initial_params(trial.points_mm, names)))
    truth = keypoint_angles(trial.points_mm, names)
    got = keypoint_angles(pts, JOINTS)
    for var in ("hip_flexion", "knee_flexion"):
        assert _rmse(got, truth, var) < 0.05, var
    knees = [JOINTS.index(f"{s}_knee") for s in ("left", "right")]
    true_knees = trial.points_mm[:, [names.index(f"{s}_knee") for s in ("left", "right")]]
    assert np.abs(pts[:, knees] - true_knees).max() < 10.0  # mm (the adduction is started from its angle)
    with pytest.raises(ValueError, match="left_heel"):
        initial_params(trial.points_mm[:, :20], names[:20])
    with pytest.raises(ValueError, match=r"the chain needs \['left_heel'"):
        fit_angles_2d(trial.detections.one_person[:, :, :20], names[:20], trial.rig, trial.detections.camera_names,
                      trial.points_mm[:, :20])


def test_fit_to_2d_keypoints_recovers_the_angles_from_a_noisy_start(trial):
    names = list(trial.skeleton.joint_names)
    truth = keypoint_angles(trial.points_mm, names)
    noisy = trial.points_mm + np.random.default_rng(0).normal(0.0, 15.0, trial.points_mm.shape)  # mm
    det = trial.detections
    fit = fit_angles_2d(det.one_person, names, trial.rig, det.camera_names, noisy, config=Fit2DConfig(steps=200))
    start = keypoint_angles(noisy, names)
    # measured: knee 1.78, hip 0.93, ankle 1.15 deg (smoothing weight 30; with 100 the walker's quicker
    # swing, its knee to 64 deg, read 3.01 / 1.58 / 1.73 and the knee's limit had been raised to 3.5)
    for var, limit in (("knee_flexion", 3.0), ("hip_flexion", 2.5), ("ankle_dorsiflexion", 3.5)):
        assert _rmse(fit.angles_deg, truth, var) < limit < _rmse(start, truth, var), var


def test_mismatched_cameras_frames_or_joints_are_named_before_the_fit(trial):
    names = list(trial.skeleton.joint_names)
    det = trial.detections
    cams = list(det.camera_names)
    with pytest.raises(ValueError, match=r"3 cameras but camera_names has 2"):
        fit_angles_2d(det.one_person, names, trial.rig, cams[:2], trial.points_mm)
    with pytest.raises(ValueError, match="named twice"):
        fit_angles_2d(det.one_person, names, trial.rig, [cams[0], cams[0], cams[1]], trial.points_mm)
    with pytest.raises(ValueError, match=r"init_points_mm: shape \(10, "):
        fit_angles_2d(det.one_person, names, trial.rig, cams, trial.points_mm[:10])
    with pytest.raises(ValueError, match=r"not in the calibration"):
        fit_angles_2d(det.one_person, names, trial.rig, ["cam_x", *cams[1:]], trial.points_mm)
