import numpy as np
import pytest
from gaitcap.reconstruction.association.pipeline import associate, default_selector
from gaitcap.reconstruction.association.selection import (
    ManualTrack,
    NearestStartTrack,
    WalkwayTrack,
    patient_detections,
    select_track_at_pixel,
)


@pytest.fixture(scope="module")
def tracked(scene3):
    tracks = associate(scene3.multi, scene3.rig)
    return scene3, tracks


def _track_of_person(scene, tracks, person):
    return int(np.bincount(tracks.detection_track[scene.identity == person]).argmax())


def test_walkway_selector_picks_the_walker_not_the_therapist_beside_or_the_bystander(tracked):
    scene, tracks = tracked
    patient = _track_of_person(scene, tracks, 0)
    assert default_selector(scene.rig).choose(tracks) == patient
    explicit = WalkwayTrack(start_mm=(-2000, 0, 0), end_mm=(2000, 0, 0), corridor_half_width_mm=400)
    scores = explicit.scores(tracks)
    assert explicit.choose(tracks) == patient
    assert scores[_track_of_person(scene, tracks, 1)] < 0.01 * scores[patient]  # outside the corridor
    beside = WalkwayTrack(start_mm=(-2000, 650, 0), end_mm=(2000, 650, 0), corridor_half_width_mm=300)
    assert beside.choose(tracks) == _track_of_person(scene, tracks, 1)


def test_nearest_start_and_manual_selection(tracked):
    scene, tracks = tracked
    bystander = _track_of_person(scene, tracks, 2)
    assert NearestStartTrack(start_mm=(800, -1700, 0)).choose(tracks) == bystander
    assert NearestStartTrack(start_mm=(-2300, 0, 0)).choose(tracks) == _track_of_person(scene, tracks, 0)
    assert ManualTrack(bystander).choose(tracks) == bystander
    with pytest.raises(ValueError, match="does not exist"):
        ManualTrack(99).choose(tracks)
    with pytest.raises(ValueError, match="start_mm and end_mm"):
        WalkwayTrack(start_mm=(0, 0, 0))


def test_patient_detections_are_the_chosen_persons_keypoints(tracked):
    scene, tracks = tracked
    det = patient_detections(scene.multi, tracks, _track_of_person(scene, tracks, 0))
    truth = np.where((scene.identity == 0)[..., None, None], scene.multi.keypoints, np.nan)
    expected = np.nansum(truth, axis=2)
    expected[~(scene.identity == 0).any(-1)] = np.nan
    np.testing.assert_array_equal(det.one_person, expected)
    assert det.camera_names == scene.multi.camera_names and det.skeleton.name == "halpe26"


def test_click_on_a_camera_preview_selects_that_person(tracked):
    scene, tracks = tracked
    c = 2
    frame = int(np.flatnonzero((scene.identity[c] >= 0).all(-1))[3])  # all three people seen
    cam = scene.rig.names[c]
    for person in range(3):
        slot = int(np.flatnonzero(scene.identity[c, frame] == person)[0])
        x, y = scene.multi.keypoints[c, frame, slot, 0, :2]  # the nose
        got = select_track_at_pixel(scene.multi, tracks, camera=cam, frame=frame, x_px=x + 3, y_px=y - 2)
        assert got == _track_of_person(scene, tracks, person)
    with pytest.raises(ValueError, match="no tracked person at pixel"):
        select_track_at_pixel(scene.multi, tracks, camera=cam, frame=frame, x_px=-500, y_px=-500)
    with pytest.raises(ValueError, match="camera 'nope'"):
        select_track_at_pixel(scene.multi, tracks, camera="nope", frame=0, x_px=0, y_px=0)
    with pytest.raises(ValueError, match="frame 999"):
        select_track_at_pixel(scene.multi, tracks, camera=cam, frame=999, x_px=0, y_px=0)


def test_walkway_is_where_the_cameras_aim(scene3):
    from gaitcap.reconstruction.association.pipeline import walkway_from_rig
    from gaitcap.reconstruction.camera import Camera, Rig, matrix_to_rodrigues

    assert walkway_from_rig(scene3.rig) is None  # all cameras aim at one spot
    cams = []
    for i, x in enumerate(np.linspace(-3000, 3000, 6)):
        side = 1 if i % 2 else -1  # cameras on both sides of a walkway along x at y = 500
        centre = np.array([x, 500 + side * 3000, 2200])
        z = np.array([x, 500, 900]) - centre
        z /= np.linalg.norm(z)
        xa = np.cross(z, [0, 0, 1.0])
        xa /= np.linalg.norm(xa)
        rot = np.stack([xa, np.cross(z, xa), z])
        cams.append(Camera(f"c{i}", (640, 480), np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]]),
                           rvec=matrix_to_rodrigues(rot), tvec_mm=-rot @ centre))
    a, b = walkway_from_rig(Rig(tuple(cams)))
    assert a[1] == pytest.approx(500, abs=1) and b[1] == pytest.approx(500, abs=1)
    assert abs(b[0] - a[0]) > 4000
