"""The walkway's heading, points turned along it and the model's coordinates turned back into the room."""

import numpy as np
import pytest
from gaitcap.reconstruction.kinematics.angles import _rx, _ry, _rz
from gaitcap.reconstruction.kinematics.walkway import coordinates_in_room, turned_points, walkway_heading_rad


def _hips(heading_deg: float, n: int = 50, back: bool = False):
    """(left, right) hips (mm, room frame) of a walk along ``heading_deg``, the second half walked back."""
    h = np.radians(heading_deg)
    fwd = np.array([np.cos(h), np.sin(h), 0.0])
    left_dir = np.array([-np.sin(h), np.cos(h), 0.0])
    s = np.linspace(0, 3000, n)[:, None]
    facing = np.where(np.arange(n)[:, None] >= n // 2, -1.0, 1.0) if back else np.ones((n, 1))
    centre = s * fwd + np.array([0, 0, 900.0])
    return centre + 100 * facing * left_dir, centre - 100 * facing * left_dir


@pytest.mark.parametrize("heading", [0.0, 45.0, -60.0, 89.0])
def test_heading_of_a_walk_and_of_one_walked_back(heading):
    for back in (False, True):
        left, right = _hips(heading, back=back)
        assert np.degrees(walkway_heading_rad(left, right)) == pytest.approx(heading, abs=1e-6)
        # turned by it, the walk runs along x, the left hip on the left (+y) going forward
        turned = turned_points(left, walkway_heading_rad(left, right))
        assert np.ptp(turned[:, 0]) > 2900 and np.ptp(turned[:, 1]) < 200.5 and turned[0, 1] == pytest.approx(100.0)
    left, right = _hips(30.0)
    left[::2] = np.nan
    assert np.degrees(walkway_heading_rad(left, right)) == pytest.approx(30.0, abs=1e-6)
    assert walkway_heading_rad(np.full((3, 3), np.nan), np.full((3, 3), np.nan)) == 0.0


def test_coordinates_fitted_along_the_walkway_are_the_same_pose_in_the_room():
    h = np.radians(45.0)
    walk = {"pelvis_tilt": np.array([6.0, 0.0, np.nan]), "pelvis_list": np.array([-3.0, -3.0, 0.0]),
            "pelvis_rotation": np.array([10.0, 0.0, 0.0]), "pelvis_tx": np.array([1.0, 0.0, 0.0]),
            "pelvis_tz": np.array([0.5, 0.0, 0.0]), "knee_angle_l": np.array([20.0, 30.0, 40.0])}
    room = coordinates_in_room(walk, h)
    # the pelvis's orientation in the room is the walkway's turned by the heading (about OpenSim's y)
    rad = {k: np.radians(v[:2]) for k, v in walk.items()}
    want = _ry(np.full(2, h)) @ _rz(rad["pelvis_tilt"]) @ _rx(rad["pelvis_list"]) @ _ry(rad["pelvis_rotation"])
    got = _rz(np.radians(room["pelvis_tilt"][:2])) @ _rx(np.radians(room["pelvis_list"][:2])) @ _ry(
        np.radians(room["pelvis_rotation"][:2]))
    assert np.allclose(got, want, atol=1e-9)
    # a level pelvis (tilt 0 along the walkway) with an obliquity of 3 deg has a tilt about the room's z
    # on the diagonal: the tilt the fit held at 0 about the room's axis was not the pelvis's own
    assert abs(room["pelvis_tilt"][1]) == pytest.approx(3.0 * np.sin(h), abs=0.05)
    # the place: a turn about the room's z is one about OpenSim's y (x' = x cos + z sin, z' = -x sin + z cos)
    assert room["pelvis_tx"][0] == pytest.approx(np.cos(h) * 1.0 + np.sin(h) * 0.5)
    assert room["pelvis_tz"][0] == pytest.approx(-np.sin(h) * 1.0 + np.cos(h) * 0.5)
    assert np.isnan(room["pelvis_tilt"][2]) and np.isnan(room["pelvis_list"][2])  # a missing angle stays missing
    assert room["knee_angle_l"] is walk["knee_angle_l"]  # the joints are not touched
