import numpy as np
import pytest
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.triangulation import dlt_triangulate, robust_triangulate


def test_dlt_is_exact_without_noise(scene):
    rig, det, gt = scene(cameras=4, frames=30, noise_px=0.0)
    res = dlt_triangulate(det, rig)
    assert res.points_mm.shape == gt.shape
    assert np.abs(res.points_mm - gt).max() < 0.5  # mm (float32 maths)


def test_robust_rejects_outliers_that_break_dlt(scene):
    rig, det, gt = scene(cameras=6, frames=30, noise_px=1.0, outliers=0.1, seed=3)
    dlt = dlt_triangulate(det, rig)
    rob = robust_triangulate(det, rig)
    err_dlt = np.nanmean(np.linalg.norm(dlt.points_mm - gt, axis=-1))
    err_rob = np.nanmean(np.linalg.norm(rob.points_mm - gt, axis=-1))
    assert err_rob < 6.0 and err_rob < 0.3 * err_dlt
    assert np.isfinite(rob.points_mm).mean() > 0.95  # the rest: no consensus among 6 views -> NaN
    assert rob.camera_weights.shape == (6, 30, 26)
    # outlier views get (almost) no weight, clean ones almost full
    c, t, j = 2, 4, 7
    kp = det.one_person.copy()
    kp[c, t, j, :2] += 250
    rob2 = robust_triangulate(MultiViewKeypoints.of_one_person(kp, det.camera_names, det.times_s, det.skeleton), rig)
    assert rob2.camera_weights[c, t, j] < 0.05
    assert rob2.camera_weights[:, t, j].sum() > 4
    assert np.linalg.norm(rob2.points_mm[t, j] - gt[t, j]) < 5.0
    assert rob2.quality[t, j] == pytest.approx(rob2.camera_weights[:, t, j].sum())


def test_fewer_than_two_views_gives_nan_not_wild(scene):
    rig, det, gt = scene(cameras=4, frames=30, noise_px=0.5)
    kp = det.one_person.copy()
    kp[1:, 0, 5, 2] = 0.1  # joint 5 in frame 0: only camera 0 is confident
    kp[:, 1, 6, :] = np.nan  # joint 6 in frame 1: seen by nobody
    kp[0, 2, 7, :2] = np.nan  # NaN pixel in one view: just a missing view
    det2 = MultiViewKeypoints.of_one_person(kp, det.camera_names, det.times_s, det.skeleton)
    for fn in (robust_triangulate, dlt_triangulate):
        res = fn(det2, rig) if fn is robust_triangulate else fn(det2, rig, min_confidence=0.5)
        assert np.isnan(res.points_mm[0, 5]).all() and np.isnan(res.points_mm[1, 6]).all()
        assert np.linalg.norm(res.points_mm[2, 7] - gt[2, 7]) < 5
        assert np.isfinite(res.points_mm).sum() == 3 * (30 * 26 - 2)
        assert res.quality[0, 5] == 0


def test_bad_input_is_named(scene):
    rig, det, _ = scene(cameras=3, frames=2)
    with pytest.raises(ValueError, match="cam9"):
        robust_triangulate(MultiViewKeypoints.of_one_person(det.one_person, ("cam0", "cam1", "cam9"), det.times_s, det.skeleton), rig)
    with pytest.raises(ValueError, match="at least 2 cameras"):
        robust_triangulate(MultiViewKeypoints.of_one_person(det.one_person[:1], ("cam0",), det.times_s, det.skeleton), rig)
    kp = det.one_person.copy()
    kp[2, 0, 0, 0] = np.inf
    with pytest.raises(ValueError, match="cam2"):
        robust_triangulate(MultiViewKeypoints.of_one_person(kp, det.camera_names, det.times_s, det.skeleton), rig)


def test_camera_order_follows_detections(scene):
    rig, det, gt = scene(cameras=4, frames=30, noise_px=0.0)
    order = [3, 1, 0, 2]
    det2 = MultiViewKeypoints.of_one_person(det.one_person[order], [det.camera_names[i] for i in order], det.times_s, det.skeleton)
    assert np.abs(robust_triangulate(det2, rig).points_mm - gt).max() < 0.5
