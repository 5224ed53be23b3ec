"""The keypoints' foot template: a rigid foot moved about recovers its shape, its turn from the knee's plane
is measured, and the template lands on a model at right angles to the shank, turned by that torsion."""

import numpy as np
import pytest
from gaitcap.reconstruction.kinematics.foot import foot_template, foot_torsion_deg, template_on_model
from scipy.spatial.transform import Rotation

# a left foot in its own frame (x forward, y up, z right), mm: ankle above, heel behind, toes ahead
FOOT = {"Ankle": np.array([60.0, 70.0, 0.0]), "Heel": np.zeros(3), "BigToe": np.array([200.0, 0.0, 0.0]),
        "SmallToe": np.array([170.0, 5.0, -40.0])}


def _moved(n: int = 40, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    rot = Rotation.from_rotvec(rng.normal(0.0, 0.4, (n, 3)))
    shift = rng.normal(0.0, 300.0, (n, 3))
    return {p: rot.apply(v) + shift for p, v in FOOT.items()}


def test_template_of_a_rigid_foot_is_its_shape():
    got = foot_template(_moved())
    for part, p in FOOT.items():
        assert np.allclose(got[part], p, atol=1e-6), part


def test_template_needs_the_ankle_heel_and_big_toe_in_enough_frames():
    pts = _moved()
    with pytest.raises(ValueError, match="no BigToe"):
        foot_template({k: v for k, v in pts.items() if k != "BigToe"})
    pts["Heel"][5:] = np.nan
    with pytest.raises(ValueError, match="5 frames have the ankle, heel and big toe"):
        foot_template(pts)


def test_template_on_a_model_stands_at_right_angles_to_the_shank_turned_by_the_torsion():
    knee, ankle = np.array([0.0, 0.0, 450.0]), np.array([0.0, 0.0, 50.0])  # room frame, z up, x forward
    for torsion in (0.0, 15.0, -20.0):
        placed = template_on_model(FOOT, ankle_centre=ankle, knee_centre=knee, forward=np.array([1.0, 0, 0]),
                                   torsion_deg=torsion)
        assert np.allclose(placed["Ankle"], ankle)
        foot = placed["BigToe"] - placed["Heel"]
        assert abs(np.dot(foot, knee - ankle)) < 1e-6  # at right angles to the shank
        assert np.degrees(np.arctan2(foot[1], foot[0])) == pytest.approx(torsion)  # + to the left (y)
        for a in FOOT:
            for b in FOOT:
                assert np.linalg.norm(placed[a] - placed[b]) == pytest.approx(np.linalg.norm(FOOT[a] - FOOT[b]))
        assert placed["Ankle"][2] > placed["BigToe"][2] == pytest.approx(placed["Heel"][2])  # the sole level


def test_torsion_is_the_foots_turn_from_the_plane_the_knee_bends_in():
    n = 30
    bend = np.radians(np.linspace(25.0, 60.0, n))
    hip = np.zeros((n, 3))
    knee = np.tile([0.0, 0.0, -400.0], (n, 1))
    ankle = knee + 400.0 * np.stack([-np.sin(bend), np.zeros(n), -np.cos(bend)], axis=1)  # shank swung back
    turn = np.radians(12.0)  # the foot points 12 deg to the left of the knee's plane
    shank_fwd = np.stack([np.cos(bend), np.zeros(n), -np.sin(bend)], axis=1)
    foot = np.cos(turn) * shank_fwd + np.sin(turn) * np.array([0.0, 1.0, 0.0])
    heel = ankle - 60.0 * foot
    toe = heel + 200.0 * foot
    assert foot_torsion_deg(hip, knee, ankle, heel, toe) == pytest.approx(12.0, abs=1e-6)
    straight = np.tile([0.0, 0.0, -800.0], (n, 1))  # a straight knee shows no plane
    assert np.isnan(foot_torsion_deg(hip, knee, straight, straight - [60, 0, 0], straight + [140, 0, 0]))
