import numpy as np
import pytest
from gaitcap.reconstruction.association.crossview import AssociationConfig, associate_frames
from gaitcap.reconstruction.keypoints import MultiViewKeypoints


def _purity(labels, identity):
    """(wrongly grouped, unassigned true detections)."""
    bad = 0
    for t in range(labels.shape[1]):
        for k in np.unique(labels[:, t][labels[:, t] >= 0]):
            ids = identity[:, t][labels[:, t] == k]
            bad += len(ids) - np.bincount(ids[ids >= 0]).max()
    return bad, int(((labels < 0) & (identity >= 0)).sum())


def test_groups_every_detection_with_the_right_people(scene3):
    people = associate_frames(scene3.multi, scene3.rig, AssociationConfig())
    bad, missed = _purity(people.labels, scene3.identity)
    assert bad == 0 and missed == 0
    # three people per frame, each root near the true pelvis
    assert np.all((people.views > 0).sum(1) == 3)
    pelvis = scene3.points_mm[:, :, 19]  # (people, T, 3)
    err = np.linalg.norm(people.root_mm[:, :, None] - pelvis.transpose(1, 0, 2)[:, None], axis=-1).min(2)
    assert np.nanmax(err) < 200  # root = mean of body joints, not the pelvis itself


def test_people_missing_from_some_views_and_empty_frames(scene3):
    kp = scene3.multi.keypoints.copy()
    kp[:, 3] = np.nan  # nobody detected in frame 3
    kp[:5, 4] = np.nan  # only 3 of 8 cameras in frame 4
    multi = MultiViewKeypoints(kp, scene3.multi.camera_names, scene3.multi.times_s, "halpe26")
    people = associate_frames(multi, scene3.rig, AssociationConfig())
    assert np.all(people.labels[:, 3] == -1) and np.all(people.views[3] == 0)
    ident = np.where(np.isfinite(kp[..., 0, 0]), scene3.identity, -1)
    bad, missed = _purity(people.labels, ident)
    assert bad == 0 and missed == 0


def test_camera_order_of_the_detections_need_not_match_the_rig(scene3):
    order = np.arange(len(scene3.rig))[::-1]
    multi = MultiViewKeypoints(scene3.multi.keypoints[order], [scene3.rig.names[i] for i in order],
                                  scene3.multi.times_s, "halpe26")
    people = associate_frames(multi, scene3.rig, AssociationConfig())
    bad, missed = _purity(people.labels, scene3.identity[order])
    assert bad == 0 and missed == 0


def test_unknown_camera_and_bad_config_are_named(scene3):
    multi = MultiViewKeypoints(scene3.multi.keypoints, ["x", *scene3.rig.names[1:]],
                                  scene3.multi.times_s, "halpe26")
    with pytest.raises(ValueError, match="'x'"):
        associate_frames(multi, scene3.rig, AssociationConfig())
    with pytest.raises(ValueError, match="ray_gap_mm"):
        AssociationConfig(ray_gap_mm=0)
    with pytest.raises(ValueError, match="no \\['left_foot_index'\\]"):
        associate_frames(scene3.multi, scene3.rig, AssociationConfig(joints=("left_foot_index",)))



def test_long_clips_are_done_in_chunks_with_the_same_result(scene3, monkeypatch):
    import gaitcap.reconstruction.association.crossview as crossview

    whole = associate_frames(scene3.multi, scene3.rig, AssociationConfig())
    monkeypatch.setattr(crossview, "CHUNK_ELEMENTS", 7 * 24**3)  # 7 frames a chunk (8 cameras x 3 slots)
    chunked = associate_frames(scene3.multi, scene3.rig, AssociationConfig())
    np.testing.assert_array_equal(chunked.labels, whole.labels)
    k = whole.views.shape[1]
    np.testing.assert_array_equal(chunked.views[:, :k], whole.views)
    np.testing.assert_allclose(chunked.root_mm[:, :k], whole.root_mm)
