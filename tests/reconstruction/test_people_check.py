"""check_one_person: a reconstruction of one person passes; views that show different people are named."""

import numpy as np
import pytest
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.methods import METHODS, reconstruct
from gaitcap.reconstruction.people_check import PersonCheckConfig, check_one_person
from gaitcap.simulator import make_trial


@pytest.fixture(scope="module")
def trial():
    return make_trial(preset="paper", seconds=4.0, cameras=4, seed=3)


def _other_person_in(trial, camera: int, offset_mm=(0.0, 1400.0, 0.0)) -> MultiViewKeypoints:
    """The trial's detections with ``camera`` seeing someone else (the walker moved by ``offset_mm``)."""
    det = trial.detections
    kp = det.one_person.copy()
    cam = trial.rig.camera(det.camera_names[camera])
    other = trial.points_mm + np.asarray(offset_mm)
    kp[camera, ..., :2] = cam.project(other.reshape(-1, 3)).reshape(*other.shape[:2], 2)
    kp[camera, ..., 2] = 0.9
    return MultiViewKeypoints.of_one_person(kp, det.camera_names, det.times_s, det.skeleton)


def test_one_person_passes(trial):
    rec = reconstruct(trial.detections, trial.rig, method=METHODS["robust"]())
    check = check_one_person(trial.detections, trial.rig, rec.points_mm)
    assert not check.mixed and check.disagreeing_fraction < 0.05, check.message
    assert check.median_error_px < 10 and check.message.startswith("one person")
    seen = (trial.detections.confident(0.5).sum(-1) >= 4).sum()  # camera frames with 4 confident joints
    assert check.judged_camera_frames == seen > 200
    d = check.to_dict()
    assert d["mixed"] is False and set(d["per_camera_error_px"]) == set(trial.detections.camera_names)


def test_a_camera_seeing_someone_else_is_named(trial):
    mixed = _other_person_in(trial, 0)
    name = mixed.camera_names[0]
    for method in ("dlt", "robust"):  # (2 other cameras see the walker: no majority)
        rec = reconstruct(mixed, trial.rig, method=METHODS[method]())
        check = check_one_person(mixed, trial.rig, rec.points_mm)
        assert check.mixed, (method, check.message)
        assert check.per_camera_disagreeing[name] > 0.9 and name in check.message, (method, check.message)
        assert "mixes people" in check.message


def test_a_reconstruction_of_someone_else_fails_in_every_view(trial):
    check = check_one_person(trial.detections, trial.rig, trial.points_mm + [0.0, 1400.0, 0.0])
    assert check.mixed and check.disagreeing_fraction > 0.9 and check.median_error_px > 100


def test_bad_input_is_named(trial):
    with pytest.raises(ValueError, match="points_mm"):
        check_one_person(trial.detections, trial.rig, trial.points_mm[:-1])
    with pytest.raises(ValueError, match="size_fraction"):
        PersonCheckConfig(size_fraction=-1.0)
