"""Data-quality measures and their warnings, on camera timestamps and detections with known faults."""

import numpy as np
import pytest
from gaitcap.reconstruction.ignored_keypoints import IgnoredKeypoints
from gaitcap.services.processing.pipeline import ring_rig
from gaitcap.services.processing.quality import (
    QualityCriteria,
    images_on_grid,
    recorded_frame_ids,
    recording_quality,
    reprojection_px,
    summary_sentence,
    with_reprojection,
)

FPS, T, C = 30.0, 300, 10  # 10 s at 30 fps
NAMES = tuple(f"cam{i}" for i in range(C))


def _stamps(jitter_ms=0.0, seed=0):
    rng = np.random.default_rng(seed)
    base = 1_700_000_000_000_000_000 + (np.arange(T) * 1e9 / FPS).astype(np.int64)
    return np.stack([base + (rng.uniform(0, jitter_ms, T) * 1e6).astype(np.int64) for _ in range(C)])


def test_keypoints_still_on_their_way_at_stop_are_not_a_stopped_camera():
    stamps = _stamps()
    stamps[2, -20:] = -1  # camera 2's detector lags 0.7 s behind the others at Stop
    stamps[4, -25:] = -1
    q = recording_quality(camera_names=NAMES, timestamps_ns=stamps, patient_confidence=None)
    assert q.warnings == (), q.warnings


def test_a_clean_recording_has_no_warnings():
    conf = np.ones((C, T, 5))
    q = recording_quality(camera_names=NAMES, timestamps_ns=_stamps(jitter_ms=5), patient_confidence=conf)
    assert q.warnings == () and not q.serious
    assert q.nominal_fps == pytest.approx(30.0, abs=0.01) and q.duration_s == pytest.approx(10.0, abs=0.01)
    assert all(c.lost == 0 and c.fps == pytest.approx(30.0) for c in q.cameras)
    assert q.spread_ms_max < 5.0 and q.coverage == 1.0


def test_a_stopped_camera_slow_cameras_and_bad_sync_are_named():
    stamps = _stamps()
    stamps[7, 126:] = -1  # camera 7 stops at 4.2 s
    for c in (1, 2, 3):  # three cameras deliver a quarter of the frames (7.5 fps)
        stamps[c, np.arange(T) % 4 != 0] = -1
    stamps[5] += 45_000_000  # camera 5 is 45 ms late on every frame
    q = recording_quality(camera_names=NAMES, timestamps_ns=stamps, patient_confidence=None,
                          expected_cameras=(*NAMES, "cam10"))
    text = summary_sentence(q.warnings)
    assert q.serious
    assert "Camera cam10 recorded nothing" in q.warnings
    assert "Camera cam7 stopped at 4.2 s" in q.warnings
    assert any(w.startswith("3 of 10 cameras below 28 fps (cam1 8 fps") for w in q.warnings), q.warnings
    assert "Cameras out of sync: up to 45 ms between cameras (limit 30 ms)" in q.warnings
    cam7 = q.cameras[7]
    judged = T - 30  # the last second is not judged per camera
    assert (cam7.expected, cam7.received, cam7.lost) == (judged, 126, judged - 126)
    assert text.endswith("; results may be less accurate")


def test_images_ending_long_before_stop_are_flagged():
    q = recording_quality(camera_names=NAMES, timestamps_ns=_stamps(), patient_confidence=None, recorded_s=13.2)
    assert q.warnings == ("No camera images for 3.2 s of the 13.2 s between Start and Stop "
                          "(the cameras stopped or fell behind)",)
    assert not recording_quality(camera_names=NAMES, timestamps_ns=_stamps(), patient_confidence=None,
                                 recorded_s=12.4).warnings
    # the limit itself (NO_IMAGES_S = 2.5 s past the images): 2.45 s is within it, 2.55 s is not
    duration = recording_quality(camera_names=NAMES, timestamps_ns=_stamps(), patient_confidence=None).duration_s
    for gap_s, flagged in ((2.45, False), (2.55, True)):
        q = recording_quality(camera_names=NAMES, timestamps_ns=_stamps(), patient_confidence=None,
                              recorded_s=duration + gap_s)
        assert bool(q.warnings) is flagged, (gap_s, q.warnings)


def test_short_recording_and_poor_coverage_are_flagged():
    stamps = _stamps()[:, :84]  # 2.8 s
    conf = np.zeros((C, 84, 5))
    conf[:2, :30] = 1.0  # seen by two cameras in 30 of 84 frames
    q = recording_quality(camera_names=NAMES, timestamps_ns=stamps, patient_confidence=conf)
    assert "Only 2.8 s recorded" in q.warnings
    assert "The patient was seen by 2 or more cameras in only 36 % of the frames" in q.warnings


def test_a_bumped_camera_stands_out_by_its_reprojection_error():
    rig = ring_rig(6)
    rng = np.random.default_rng(1)
    points = rng.uniform(-400, 400, (40, 3, 3)) + np.array([0.0, 0.0, 900.0])
    kp = np.concatenate([rig.project(points), np.ones((6, 40, 3, 1))], axis=-1)
    kp[..., :2] += rng.normal(0, 1.0, kp[..., :2].shape)
    kp[4, ..., 0] += 25.0  # camera 4 was knocked: its detections sit 25 px off the reconstruction
    errors = reprojection_px(points, kp, rig)
    assert errors["cam4"] == pytest.approx(25.0, abs=2.0) and errors["cam0"] < 2.0
    q = recording_quality(camera_names=tuple(rig.names), timestamps_ns=_stamps()[:6], patient_confidence=None)
    q = with_reprojection(q, errors)
    assert [w for w in q.warnings if "reprojection" in w] == [
        f"Camera cam4: reprojection error {errors['cam4']:.1f} px, far above the others "
        f"({np.median([e for n, e in errors.items() if n != 'cam4']):.1f} px); it may have been moved, recalibrate"]


def test_criteria_are_checked():
    with pytest.raises(ValueError, match="min_fps_fraction"):
        QualityCriteria(min_fps_fraction=0)
    assert QualityCriteria().min_fps_at(30.0) == 28.0 and QualityCriteria().min_fps_at(15.0) == 14.0
    with pytest.raises(ValueError, match="min_coverage"):
        QualityCriteria(min_coverage=2)


def test_a_camera_restarted_during_the_trial_is_named():
    stamps = _stamps()
    stamps[3, 100:130] = -1  # camera 3's node restarted: a second without images, then its frames again
    q = recording_quality(camera_names=NAMES, timestamps_ns=stamps, patient_confidence=None, restarts={"cam3": 1})
    assert q.serious and "Camera cam3 restarted during the trial (1 time)" in summary_sentence(q.warnings)
    again = with_reprojection(q, {})
    assert again.restarts == {"cam3": 1} and any("cam3 restarted" in w for w in again.warnings)


# -- the recorder's images tell a stopped camera from a detector that fell behind ---------------------
FIRST_ID = 5000  # frame ids of the keypoint grid: FIRST_ID .. FIRST_ID + T - 1


def _summary(frame_ids: dict[str, list[int]]) -> dict:
    """The recorder's summary for images with these frame ids, as the recorder itself writes it."""
    from gaitcap.services.nodes.recorder import CameraTally

    last = max(max(ids) for ids in frame_ids.values() if ids)
    return {"cameras": {c: CameraTally(frames=len(ids), frame_ids=list(ids)).summary(last)
                        for c, ids in frame_ids.items()}}


def _with_images(stamps, images: dict[str, list[int]], **kw):
    return recording_quality(camera_names=NAMES, timestamps_ns=stamps, patient_confidence=None,
                             frame_ids=np.arange(FIRST_ID, FIRST_ID + stamps.shape[1]),
                             recorded_frames=recorded_frame_ids(_summary(images)), **kw)


def test_recorded_frame_ids_come_back_from_the_recorder_summary():
    ids = [3, 4, 5, 9, 10, 20]
    got = recorded_frame_ids(_summary({"camA": ids, "camB": list(range(3, 31))}))
    assert got["camA"].tolist() == ids and got["camB"].tolist() == list(range(3, 31))
    assert recorded_frame_ids({}) == {}


def test_keypoints_missing_for_recorded_frames_are_the_detector_falling_behind():
    stamps = _stamps()
    stamps[7, 126:] = -1  # no keypoints for camera 7 after 4.2 s, but its images were all recorded
    stamps[2, 50:54] = -1  # 4 frames of camera 2 without keypoints
    every = {n: list(range(FIRST_ID, FIRST_ID + T)) for n in NAMES}
    q = _with_images(stamps, every)
    judged = T - 30
    assert not any("stopped" in w for w in q.warnings), q.warnings
    assert q.warnings == (f"The detector fell behind on 1 of 10 cameras: no keypoints for frames the cameras "
                          f"delivered and the recording holds (cam7 {judged - 126} of {judged} frames)",)
    cam7 = q.cameras[7]
    assert (cam7.source, cam7.received, cam7.lost, cam7.without_keypoints) == ("images", judged, 0, judged - 126)
    assert q.cameras[2].without_keypoints == 4  # under the 2 % criterion: counted, not a warning


def test_a_camera_whose_images_stop_is_still_a_stopped_camera():
    stamps = _stamps()
    stamps[7, 126:] = -1
    images = {n: list(range(FIRST_ID, FIRST_ID + T)) for n in NAMES}
    images["cam7"] = list(range(FIRST_ID, FIRST_ID + 126))  # the camera itself stopped at 4.2 s
    q = _with_images(stamps, images)
    assert q.warnings == ("Camera cam7 stopped at 4.2 s", "1 of 10 cameras lost frames (cam7 144 of 270)")
    assert q.cameras[7].without_keypoints == 0


def test_a_detector_far_behind_at_stop_is_not_missing_camera_images():
    stamps = _stamps()[:, : T - 90]  # keypoints end 3 s before the images: the detector had not caught up
    q = _with_images(stamps, {n: list(range(FIRST_ID, FIRST_ID + T)) for n in NAMES}, recorded_s=10.2)
    assert q.duration_s == pytest.approx(10.0, abs=0.01)
    assert not any("No camera images" in w or "stopped" in w for w in q.warnings), q.warnings
    assert any(w.startswith("The detector fell behind on 10 of 10 cameras") and "cam0 60 of 270 frames" in w
               for w in q.warnings), q.warnings


def test_a_camera_with_images_but_no_keypoints_is_named_after_the_fit_too():
    images = {n: list(range(FIRST_ID, FIRST_ID + T)) for n in (*NAMES, "cam10", "cam11")}
    images["cam11"] = []
    q = recording_quality(camera_names=NAMES, timestamps_ns=_stamps(), patient_confidence=None,
                          expected_cameras=(*NAMES, "cam10", "cam11"),
                          frame_ids=np.arange(FIRST_ID, FIRST_ID + T), recorded_frames=recorded_frame_ids(_summary(images)))
    expected = ("The detector produced no keypoints for camera cam10 (its 300 frames were recorded)",
                "Camera cam11 recorded nothing")
    assert q.warnings == expected
    assert with_reprojection(q, {}).warnings == expected
    with pytest.raises(ValueError, match="frame_ids"):
        recording_quality(camera_names=NAMES, timestamps_ns=_stamps(), patient_confidence=None,
                          recorded_frames={"cam0": np.arange(3)})


def test_keypoints_of_frames_before_the_first_image_do_not_count():
    stamps = _stamps()  # keypoints from FIRST_ID; the recorder's images only from FIRST_ID + 5 (Start)
    q = _with_images(stamps, {n: list(range(FIRST_ID + 5, FIRST_ID + T)) for n in NAMES})
    assert q.warnings == () and q.duration_s == pytest.approx((T - 5) / FPS, abs=0.01)
    assert all(c.lost == 0 and c.without_keypoints == 0 and c.first_s == 0.0 for c in q.cameras)


# -- recovered recordings, restarted cameras and the recorder's own drops ------------------------------
def _image_times(stamps, frames=None) -> dict[str, np.ndarray]:
    """Camera timestamps (ns) of the images of these grid columns (all by default) per camera."""
    cols = np.arange(stamps.shape[1]) if frames is None else np.asarray(frames)
    return {n: _stamps()[c, cols] for c, n in enumerate(NAMES)}


def test_images_counted_from_a_recovered_file_are_placed_on_the_keypoint_grid():
    stamps = _stamps(jitter_ms=4.0)
    stamps[5, 200:] = -1  # the detector fell behind on camera 5; its images are all in the file
    times = {n: t + (2_000_000 if n == "cam5" else 0) for n, t in _image_times(stamps).items()}  # 2 ms late
    images = images_on_grid(times, camera_names=NAMES, timestamps_ns=stamps,
                            frame_ids=np.arange(FIRST_ID, FIRST_ID + T))
    assert all(ids.tolist() == list(range(FIRST_ID, FIRST_ID + T)) for ids in images.values())
    q = recording_quality(camera_names=NAMES, timestamps_ns=stamps, patient_confidence=None,
                          frame_ids=np.arange(FIRST_ID, FIRST_ID + T), recorded_frames=images, recovered=True)
    assert q.recovered and q.cameras[5].source == "images" and q.cameras[5].lost == 0
    assert q.warnings[0].startswith("The recording was recovered after the recorder stopped unexpectedly")
    assert any(w.startswith("The detector fell behind on 1 of 10 cameras") for w in q.warnings), q.warnings
    with pytest.raises(ValueError, match="no detections with camera timestamps"):
        images_on_grid(times, camera_names=NAMES, timestamps_ns=np.full((C, T), -1), frame_ids=np.arange(T))


def test_a_restarted_camera_is_judged_by_its_images_placed_by_time():
    stamps = _stamps()
    stamps[3, 100:130] = -1  # camera 3 restarted: a second without images, then its counter from 0 again
    ids = {n: list(range(FIRST_ID, FIRST_ID + T)) for n in NAMES}
    ids["cam3"] = list(range(FIRST_ID, FIRST_ID + 100)) + list(range(170))  # what its recorder summary holds
    summary_ids = recorded_frame_ids(_summary(ids))
    assert "cam3" not in summary_ids  # its ids are another count: not taken as frames 0..169 nor duplicates
    placed = images_on_grid({"cam3": _stamps()[3, np.r_[0:100, 130:T]]}, camera_names=NAMES,
                            timestamps_ns=stamps, frame_ids=np.arange(FIRST_ID, FIRST_ID + T))
    q = recording_quality(camera_names=NAMES, timestamps_ns=stamps, patient_confidence=None,
                          frame_ids=np.arange(FIRST_ID, FIRST_ID + T), recorded_frames={**summary_ids, **placed},
                          restarts={"cam3": 1})
    cam3 = q.cameras[3]
    assert (cam3.source, cam3.received, cam3.lost, cam3.skips, cam3.without_keypoints) == ("images", 240, 30, 1, 0)
    assert q.warnings == ("Camera cam3 restarted during the trial (1 time); its frames after the restart are "
                          "placed by their timestamps", "1 of 10 cameras below 28 fps (cam3 27 fps)",
                          "1 of 10 cameras lost frames (cam3 30 of 270)")


def test_images_the_recorder_dropped_are_the_recorders_not_the_cameras():
    stamps = _stamps()
    stamps[4, 200:212] = -1  # 12 images of camera 4 never written (the recorder's queue was full)
    images = {n: list(range(FIRST_ID, FIRST_ID + T)) for n in NAMES}
    images["cam4"] = [i for i in images["cam4"] if not FIRST_ID + 200 <= i < FIRST_ID + 212]
    q = _with_images(stamps, images, recorder_dropped={"cam4": 12, "cam1": 0})
    assert q.warnings == ("The recorder dropped 12 images of camera cam4 (disk or CPU too slow)",)
    assert (q.cameras[4].lost, q.cameras[4].recorder_dropped, q.cameras[4].camera_lost) == (12, 12, 0)
    assert with_reprojection(q, {}).warnings == q.warnings
    blamed = _with_images(stamps, images)  # without the recorder's count, the camera lost them
    assert blamed.warnings == ("1 of 10 cameras lost frames (cam4 12 of 270)",)


def test_keypoint_messages_with_stray_frame_ids_are_named_and_a_camera_with_only_those_is_said_so():
    q = recording_quality(camera_names=NAMES[:9], timestamps_ns=_stamps()[:9], patient_confidence=None,
                          expected_cameras=NAMES,
                          ignored={"cam1": IgnoredKeypoints(4, (2**40, 2**40 + 1, 2**40 + 2)),
                                   "cam9": IgnoredKeypoints(1, (7,)), "cam2": IgnoredKeypoints()})
    assert q.serious and q.absent == {} and {n: i.strays for n, i in q.ignored_keypoints.items()} == {"cam1": 4, "cam9": 1}
    assert q.warnings == (
        "Camera cam1: 4 keypoint messages with frame ids far outside the recording (1099511627776, 1099511627777, "
        "1099511627778, ...) were ignored",
        "Camera cam9: its only keypoint message had a frame id far outside the recording (7) and was ignored: the "
        "camera has no keypoints")
    assert {n: i["stray_frame_ids"] for n, i in with_reprojection(q, {}).to_dict()["ignored_keypoints"].items()} \
        == {"cam1": [2**40, 2**40 + 1, 2**40 + 2], "cam9": [7]}


def test_keypoint_messages_that_could_not_be_read_are_named_and_a_camera_left_with_none_is_said_so():
    q = recording_quality(camera_names=NAMES[:8], timestamps_ns=_stamps()[:8], patient_confidence=None,
                          expected_cameras=NAMES,
                          ignored={"cam3": IgnoredKeypoints(unreadable={"missing 'skeleton'": 2}),
                                   "cam5": IgnoredKeypoints(unreadable={"not JSON": 1, "missing 'people'": 2}),
                                   "cam8": IgnoredKeypoints(unreadable={"missing 'timestamp_ns'": 1}),
                                   "cam9": IgnoredKeypoints(3, (2**40,), unreadable={"not JSON": 4})})
    assert q.serious and q.absent == {}
    assert q.ignored_keypoints["cam5"].unreadable == {"not JSON": 1, "missing 'people'": 2}
    assert q.warnings == (
        "Camera cam3: 2 keypoint messages could not be read and were ignored (missing 'skeleton')",
        "Camera cam5: 3 keypoint messages could not be read and were ignored (2 missing 'people', 1 not JSON)",
        "Camera cam8: its only keypoint message could not be read (missing 'timestamp_ns'): the camera has no "
        "keypoints",
        "Camera cam9: 4 keypoint messages could not be read (not JSON), and the other 3 had frame ids far outside "
        "the recording (1099511627776, ...): the camera has no keypoints")
    assert with_reprojection(q, {}).ignored_keypoints == q.ignored_keypoints


def test_keypoint_messages_left_out_for_their_timestamp_are_said_to_be_so():
    q = recording_quality(camera_names=NAMES[:9], timestamps_ns=_stamps()[:9], patient_confidence=None,
                          expected_cameras=NAMES,
                          ignored={"cam1": IgnoredKeypoints(1, (50,), mistimed=1),
                                   "cam2": IgnoredKeypoints(3, (2**40, 7, 8), mistimed=2),
                                   "cam9": IgnoredKeypoints(2, (3, 4), mistimed=2)})
    assert q.warnings == (
        "Camera cam1: 1 keypoint message with a timestamp far from its frame's (50) was ignored",
        "Camera cam2: 3 keypoint messages with frame ids far outside the recording (1) or timestamps far from "
        "their frames' (2) (1099511627776, 7, 8) were ignored",
        "Camera cam9: all its 2 keypoint messages had timestamps far from their frames' (3, 4) and were ignored: "
        "the camera has no keypoints")
    assert {n: i.mistimed for n, i in with_reprojection(q, {}).ignored_keypoints.items()} \
        == {"cam1": 1, "cam2": 2, "cam9": 2}


def test_frame_sets_held_to_their_grid_are_said_in_the_trials_quality_not_warned():
    from types import SimpleNamespace

    from gaitcap.acquisition.recording.reader import frame_times_s
    from gaitcap.reconstruction.keypoints import MultiViewKeypoints
    from gaitcap.services.processing.trial import trial_quality

    period, t0 = 33_333_333, 1_700_000_000_000_000_000
    stamps = t0 + np.arange(40) * period + np.array([[0], [-int(0.4 * period)]])
    people, rig = np.full((2, 40, 1, 17, 3), 0.9), SimpleNamespace(names=("cam0", "cam1"))

    def quality():
        kp = MultiViewKeypoints(people, ("cam0", "cam1"), frame_times_s(stamps), "coco17", timestamps_ns=stamps)
        return trial_quality(SimpleNamespace(recorded=None), kp, kp.patient(), rig, QualityCriteria())

    assert "frame_times" not in quality().checks
    stamps[1, 10], stamps[0, 11] = -1, -1  # a late frame alone in its set, the next set's from the other camera
    stamps[0, 10], stamps[1, 11] = t0 + int(10.7 * period), t0 + 11 * period - int(0.4 * period)
    q = quality()
    check = q.checks["frame_times"]
    assert check["held_frame_sets"] == 1 and "1 of 40 frame sets were stamped out of order" in check["notes"][0]
    assert not any("stamped out of order" in w for w in q.warnings)  # said, not a warning: moved < half a frame
