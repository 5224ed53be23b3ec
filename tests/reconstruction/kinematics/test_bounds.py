"""A model coordinate resting on the bound of its range is named (never passed over in silence)."""

import numpy as np
from gaitcap.reconstruction.kinematics.bounds import MIN_FRAMES, bound_hits


def test_a_coordinate_on_its_bound_is_named_with_how_often():
    sub = np.r_[np.full(40, -20.0), np.linspace(-19, 5, 60), [np.nan] * 5]  # degrees
    knee = np.r_[np.zeros(MIN_FRAMES - 1), np.linspace(5.0, 60.0, 50)]  # touches 0 in too few frames
    tx = np.full(10, 0.25)  # m
    ranges = {"subtalar_angle_r": (-20.0, 20.0, True), "knee_angle_r": (0.0, 120.0, True),
              "pelvis_tx": (-5.0, 0.25, False), "absent": (0.0, 1.0, True)}
    hits = bound_hits({"subtalar_angle_r": sub, "knee_angle_r": knee, "pelvis_tx": tx}, ranges)
    assert [(h.coordinate, h.bound, h.frames, h.fitted) for h in hits] == [
        ("subtalar_angle_r", "lower", 40, 100), ("pelvis_tx", "upper", 10, 10)]
    assert hits[0].message() == ("subtalar_angle_r rests on its lower bound (-20 deg) in 40 of 100 frames (40 %): "
                                 "the fit could not follow the keypoints there")
    assert "(0.25 m)" in hits[1].message()
    assert hits[0].to_dict()["fraction"] == 0.4 and hits[0].to_dict()["unit"] == "deg"
    assert bound_hits({"knee_angle_r": np.full(5, np.nan)}, ranges) == []
