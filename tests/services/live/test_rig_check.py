"""The recorder's summary at Stop in plain words: dropped images named per camera, apart from keypoints."""

from gaitcap.services.live.rig_check import recorder_warnings


def test_dropped_images_are_counted_per_camera_apart_from_keypoint_messages():
    summary = {"dropped_frames": {"cam01": 5, "cam02": 3, "cam03": 0}, "dropped_images": {"cam01": 4, "cam02": 0}}
    (warning,) = recorder_warnings(summary)
    assert warning == ("The recorder dropped 4 camera images (cam01 4) and 4 keypoint and status messages "
                       "because the disk or CPU was too slow")
    (warning,) = recorder_warnings({"dropped_frames": {"cam02": 2}, "dropped_images": {}})
    assert warning == ("The recorder dropped 0 camera images and 2 keypoint and status messages because the disk "
                       "or CPU was too slow")


def test_a_clean_summary_gives_no_warning_and_an_error_is_named():
    assert recorder_warnings({"dropped_frames": {"cam01": 0}, "dropped_images": {}}) == []
    assert recorder_warnings({"error": "disk full writing cam04"}) == ["Recording error: disk full writing cam04"]
