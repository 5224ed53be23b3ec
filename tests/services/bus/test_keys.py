import pytest
from gaitcap.services.bus.keys import DEFAULT_PREFIX, Keys, check_name


def test_key_expressions():
    k = Keys("gaitcap/lab1")
    assert k.image("cam01") == "gaitcap/lab1/camera/cam01/image"
    assert k.image() == "gaitcap/lab1/camera/*/image"
    assert k.status("cam01") == "gaitcap/lab1/camera/cam01/status"
    assert k.keypoints("c-2") == "gaitcap/lab1/keypoints/c-2"
    assert k.recorder_start == "gaitcap/lab1/recorder/start" and k.recorder_events.endswith("/recorder/events")
    assert k.alive("recorder") == "gaitcap/lab1/alive/recorder" and k.alive() == "gaitcap/lab1/alive/**"
    assert k.recording("T1") == "gaitcap/lab1/recorder/recording/T1" and k.recording().endswith("/recording/*")
    assert k.camera_of("gaitcap/lab1/camera/cam01/image") == "cam01"
    assert k.camera_of("gaitcap/lab1/keypoints/cam02") == "cam02"
    assert Keys().prefix == DEFAULT_PREFIX


def test_bad_names_and_prefixes():
    for bad in ("a/b", "cam*", "", "x y"):
        with pytest.raises(ValueError, match="camera"):
            check_name(bad, what="camera")
    with pytest.raises(ValueError, match="prefix"):
        Keys("gaitcap/*")
    with pytest.raises(ValueError, match="names no camera"):
        Keys().camera_of("other/camera/x/image")

