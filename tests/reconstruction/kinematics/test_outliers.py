"""Gross keypoint outliers before the model fit: a keypoint far from where the body puts it is flagged,
ordinary movement (a swinging wrist) and missing keypoints are not."""

import numpy as np
import pytest
from gaitcap.reconstruction.kinematics.outliers import gross_outliers

NAMES = ("LHip", "RHip", "Nose", "LWrist")


def _walk(frames: int = 60) -> np.ndarray:
    t = np.arange(frames) / 30.0
    pts = np.zeros((frames, len(NAMES), 3))
    pts[:, 0] = [0.0, 90.0, 900.0]
    pts[:, 1] = [0.0, -90.0, 900.0]
    pts[:, :, 0] += 1300.0 * t[:, None]  # walking forward at 1.3 m/s
    pts[:, 2] = pts[:, 0] + [100.0, -90.0, 650.0]
    swing = 250.0 * np.sin(2 * np.pi * t)  # the wrist swings +-250 mm
    pts[:, 3] = pts[:, 0] + np.stack([swing, np.full_like(t, 150.0), np.full_like(t, -100.0)], -1)
    return pts


def test_a_wrong_match_is_flagged_and_movement_is_not():
    pts = _walk()
    pts[10:13, 2] += [1500.0, 600.0, -200.0]  # the nose triangulated far away in three frames
    pts[20, 3] = np.nan
    bad = gross_outliers(pts, NAMES, centre=("LHip", "RHip"))
    assert bad.shape == (60, 4)
    assert np.array_equal(np.nonzero(bad[:, 2])[0], [10, 11, 12])
    assert not bad[:, [0, 1, 3]].any()


def test_missing_centre_keypoint_is_named():
    with pytest.raises(ValueError, match="RHip"):
        gross_outliers(_walk(), ("LHip", "Hip", "Nose", "LWrist"), centre=("LHip", "RHip"))
