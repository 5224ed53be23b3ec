import numpy as np
import pytest
from gaitcap.reconstruction.association.boxes import BoxConfig, person_boxes


def test_boxes_contain_the_person_with_padding_and_stay_in_the_image(scene3):
    rig, pts = scene3.rig, scene3.points_mm[0, :10]
    boxes = person_boxes(rig, pts, BoxConfig(padding_fraction=0.1, min_padding_px=5))
    assert boxes.shape == (len(rig), 10, 4)
    px = rig.project(pts)  # (C, T, J, 2)
    for c, cam in enumerate(rig.cameras):
        w, h = cam.size_px
        b = boxes[c]
        assert np.all(b[:, :2] >= 0) and np.all(b[:, 2] <= w) and np.all(b[:, 3] <= h)
        inside = px[c].clip(0, [w, h])
        assert np.all(inside >= b[:, None, :2] - 1e-9) and np.all(inside <= b[:, None, 2:] + 1e-9)
        span = px[c].max(1) - px[c].min(1)
        lo = px[c].min(1) - b[:, :2]
        assert np.all(np.isclose(lo, np.maximum(0.1 * span, 5)) | np.isclose(b[:, :2], 0))


def test_no_box_behind_the_camera_or_outside_the_image(scene3):
    rig = scene3.rig
    cam = rig.cameras[0]
    behind = cam.center_mm - 3000 * (cam.rotation[2])  # 3 m behind camera 0
    far_side = cam.center_mm + cam.rotation.T @ np.array([5000.0, 0, 1000])  # in front, far right
    pts = np.stack([behind + np.random.default_rng(0).normal(0, 200, (26, 3)),
                    far_side + np.zeros((26, 3)), np.full((26, 3), np.nan)])
    boxes = person_boxes(rig, pts)
    assert np.isnan(boxes[0, 0]).all()
    assert np.isnan(boxes[0, 1]).all() and np.isnan(boxes[:, 2]).all()


def test_bad_points_shape_and_config():
    with pytest.raises(ValueError, match="points_mm"):
        person_boxes(None, np.zeros((4, 3)))
    with pytest.raises(ValueError, match="BoxConfig"):
        BoxConfig(padding_fraction=-1)


def test_track_boxes_use_the_tracks_camera_order(scene3):
    from gaitcap.reconstruction.association import associate, track_boxes

    tracks = associate(scene3.multi, scene3.rig)
    names = list(reversed(tracks.camera_names))
    boxes = track_boxes(scene3.rig, tracks.points_mm[0], names, BoxConfig(padding_fraction=0.3))
    direct = person_boxes(scene3.rig, tracks.points_mm[0], BoxConfig(padding_fraction=0.3))
    np.testing.assert_allclose(boxes, direct[::-1])
    assert np.isfinite(boxes).all()
