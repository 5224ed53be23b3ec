"""Calibration from people alone (no board) on the synthetic clinic: poses from the walk, scale from the
subject's entered height, world frame from the floor."""

from __future__ import annotations

import numpy as np
import pytest
from gaitcap.reconstruction.calibration.compare import world_change
from gaitcap.reconstruction.calibration.geometry import rotation_angle_deg
from gaitcap.reconstruction.calibration.people_bundle import PeopleBundleConfig
from gaitcap.reconstruction.calibration.people_init import (
    PeopleCalibrationConfig,
    calibrate_from_people,
    stature_mm,
)
from gaitcap.simulator import make_trial


@pytest.fixture(scope="module")
def trial():
    return make_trial(preset="paper", seconds=8.0, cameras=5, seed=5)


def test_stature_of_the_true_points(trial):
    assert stature_mm(trial.points_mm, trial.detections) == pytest.approx(trial.params.height_mm, rel=0.01)


def test_rig_from_people_alone(trial):
    config = PeopleCalibrationConfig(bundle=PeopleBundleConfig(prior_rotation_deg=5.0, prior_shift_mm=300.0,
                                                               max_frames=80))
    result = calibrate_from_people(trial.detections, trial.rig, height_mm=trial.params.height_mm, config=config)
    ref, got = list(trial.rig), [result.rig[n] for n in trial.rig.names]
    turn, shift = world_change(ref, got)  # the walk's world frame is not the room's: compare the rig's shape
    centres = [np.linalg.norm(turn.T @ (b.center_mm - shift) - a.center_mm) for a, b in zip(ref, got, strict=True)]
    rotations = [rotation_angle_deg(b.rotation @ turn, a.rotation) for a, b in zip(ref, got, strict=True)]
    # a small rig (5 cameras, 8 s, 80 frames) for speed: the targets (0.5 deg, 15 mm) are measured on
    # the full clinic by bench/rig_check.py; a wrong scale (1 % is 40 mm at 4 m) or pose fails these
    assert max(rotations) < 1.0, rotations
    assert max(centres) < 60.0, centres
    assert result.stature_mm == pytest.approx(trial.params.height_mm, rel=0.005)


def test_height_must_be_a_height(trial):
    with pytest.raises(ValueError, match="height_mm"):
        calibrate_from_people(trial.detections, trial.rig, height_mm=1.75)
