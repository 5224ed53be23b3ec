"""Comparing calibrations: world-frame differences and the rig's own shape are told apart."""

import numpy as np
import pytest
from gaitcap.reconstruction.calibration.compare import compare_rigs
from gaitcap.reconstruction.camera import Rig, matrix_to_rodrigues
from gaitcap.simulator.room import build_rig


def _moved(rig: Rig, turn: np.ndarray, shift_mm: np.ndarray) -> Rig:
    """The same cameras in a world turned by ``turn`` and shifted: X_new = turn X_old + shift."""
    cams = []
    for cam in rig:
        rot = cam.rotation @ turn.T
        centre = turn @ cam.center_mm + shift_mm
        cams.append(cam.replace(rvec=matrix_to_rodrigues(rot), tvec_mm=-rot @ centre))
    return Rig(tuple(cams))


def test_identical_rigs():
    rig = build_rig(5, seed=0)
    cmp = compare_rigs(rig, rig)
    assert cmp.centre_mm_max < 1e-9 and cmp.rotation_deg_max < 1e-4 and cmp.world_shift_mm < 1e-9


def test_a_world_turned_about_the_vertical_is_a_heading_not_a_shape_change():
    rig = build_rig(6, seed=0)
    a = np.radians(0.1)
    turn = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    cmp = compare_rigs(rig, _moved(rig, turn, np.array([2.0, 0.0, 0.0])))
    assert abs(cmp.world_heading_deg - 0.1) < 1e-6 and cmp.world_tilt_deg < 1e-6
    assert cmp.aligned_centre_mm_max < 1e-6  # the rig's shape is unchanged
    assert cmp.centre_mm_max > 5.0  # but the cameras moved in the world (0.1 deg at ~4 m, plus 2 mm)
    assert all(abs(c.rotation_deg - 0.1) < 1e-4 for c in cmp.cameras)


def test_one_camera_moved():
    rig = build_rig(6, seed=0)
    cams = list(rig)
    cams[2] = cams[2].replace(tvec_mm=cams[2].tvec_mm + [0.0, 0.0, 10.0])
    cmp = compare_rigs(rig, Rig(tuple(cams)))
    worst = max(cmp.cameras, key=lambda c: c.aligned_centre_mm)
    assert worst.name == "cam03" and abs(cmp.cameras[2].centre_mm - 10.0) < 1e-9


def test_different_cameras_are_an_error():
    with pytest.raises(ValueError, match="different cameras"):
        compare_rigs(build_rig(5, seed=0), build_rig(4, seed=0))


def _scaled(rig: Rig, scale: float) -> Rig:
    """The same rig measured in other units (another tool's world): centres scaled, rotations kept."""
    return Rig(tuple(c.replace(tvec_mm=c.tvec_mm * scale) for c in rig))


def test_similarity_takes_out_another_tools_world_and_units():
    from gaitcap.reconstruction.calibration.compare import compare_similar
    from scipy.spatial.transform import Rotation

    rig = build_rig(5, seed=1)
    turn = Rotation.from_euler("xyz", [30, -20, 75], degrees=True).as_matrix()
    other = _scaled(_moved(rig, turn, np.array([400.0, -250.0, 90.0])), 0.001)  # metres, its own frame
    cmp = compare_similar(rig, other)
    assert abs(cmp.scale - 1000.0) < 1e-6 and cmp.centre_mm_max < 1e-6 and cmp.rotation_deg_max < 1e-4
    cams = list(other)
    tilted = Rotation.from_rotvec([0, np.radians(0.5), 0]).as_matrix() @ cams[1].rotation  # turned in place
    cams[1] = cams[1].replace(rvec=matrix_to_rodrigues(tilted), tvec_mm=-tilted @ cams[1].center_mm)
    cmp = compare_similar(rig, Rig(tuple(cams)))
    assert abs(cmp.rotation_deg[1] - 0.5) < 1e-4 and max(np.delete(cmp.rotation_deg, 1)) < 1e-4
    with pytest.raises(ValueError, match="3 or more cameras"):
        compare_similar(rig.subset(["cam01", "cam02"]), rig.subset(["cam01", "cam02"]))
