import numpy as np
import pytest
from gaitcap.simulator import make_trial
from gaitcap.simulator.render import background, render_frame, scaled_camera
from gaitcap.simulator.room import safe_project


@pytest.fixture(scope="module")
def trial():
    return make_trial("clean", seconds=6.0, cameras=4, people=2, seed=1)


def test_render_frame_draws_people_over_the_room(trial):
    for cam_i in range(4):
        img = render_frame(trial, cam_i, 120, size_px=(640, 480))
        assert img.shape == (480, 640, 3) and img.dtype == np.uint8
        bg = background(scaled_camera(trial.rig[cam_i], (640, 480)))
        changed = np.any(img != bg, axis=-1)
        # the person is drawn where the patient's joints project
        cam = scaled_camera(trial.rig[cam_i], (640, 480))
        px = cam.project(trial.points_mm[120])
        inside = cam.in_image(px)
        if inside.sum() > 10:
            hits = changed[np.clip(px[inside, 1].astype(int), 0, 479), np.clip(px[inside, 0].astype(int), 0, 639)]
            assert hits.mean() > 0.8


def test_drawing_a_frame_leaves_the_cached_room_empty(trial):
    cam = scaled_camera(trial.rig[1], (320, 200))
    room = background(cam)
    first = render_frame(trial, 1, 120, size_px=(320, 200))
    assert np.any(first != room) and first.flags.writeable
    assert np.array_equal(background(cam), room)  # the people were drawn on a copy
    assert np.array_equal(render_frame(trial, 1, 120, size_px=(320, 200)), first)


def test_render_size_and_errors(trial):
    assert render_frame(trial, 0, 0, size_px=(320, 200)).shape == (200, 320, 3)
    with pytest.raises(ValueError, match="frame_index"):
        render_frame(trial, 0, 10_000)
    with pytest.raises(ValueError, match="camera_index"):
        render_frame(trial, 9, 0)


def test_scaled_camera_matches_a_resize(trial):
    cam = trial.rig[0]
    small = scaled_camera(cam, (640, 480))
    pts = trial.points_mm[60]
    big_px = cam.project(pts)
    assert np.allclose(small.project(pts), big_px * np.array([640 / 1920, 480 / 1200]), atol=1e-9)
    # safe projection agrees inside the valid field and never folds back into the image
    assert np.allclose(safe_project(cam, pts), big_px, atol=1e-9)
    far = np.array([[cam.center_mm[0] + 10, cam.center_mm[1] + 10, 0.0]])
    p = safe_project(cam, far)
    assert np.all(np.isnan(p)) or not cam.in_image(p)[0]
