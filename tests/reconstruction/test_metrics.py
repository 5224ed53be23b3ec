import numpy as np
import pytest
from gaitcap.reconstruction.metrics import compute_metrics, ground_truth_errors


def test_metrics_of_truth_and_of_a_shifted_copy(scene):
    rig, det, gt = scene(cameras=4, frames=10, noise_px=0.0, rigid=True)
    m = compute_metrics(gt, det, rig, truth_mm=gt)
    assert m["GC_5"] == pytest.approx(1.0) and m["MPJPE"] == pytest.approx(0.0, abs=1e-9)
    assert m["L_skeleton"] < 1e-6 and m["L_reproj"] < 1e-6
    assert set(m["camera_error_px"]) == set(det.camera_names)
    moved = gt + np.array([30.0, -30.0, 30.0])
    m2 = compute_metrics(moved, det, rig, truth_mm=gt)
    assert m2["MPJPE"] == pytest.approx(30 * np.sqrt(3)) and m2["heel_error"] == pytest.approx(30 * np.sqrt(3))
    assert m2["GC_5"] < 0.2 and m2["GC_20"] > m2["GC_5"]
    holes = gt.copy()
    holes[0, :5] = np.nan
    m3 = compute_metrics(holes, det, rig, truth_mm=gt)
    assert m3["nan_fraction"] == pytest.approx(5 / gt[..., 0].size)
    assert m3["GC_5"] < 1.0  # a NaN point is a miss


def test_ground_truth_shape_mismatch_is_named():
    with pytest.raises(ValueError, match="ground truth"):
        ground_truth_errors(np.zeros((3, 2, 3)), np.zeros((4, 2, 3)), ["a", "b"])
