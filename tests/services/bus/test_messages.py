"""Typed bus messages: round trips, bounds and the error that names the field; path confinement."""

import json
import os

import pytest
from gaitcap.acquisition.keypoint_message import MAX_PEOPLE
from gaitcap.reconstruction.calibration_io import rig_from_toml_text, rig_to_toml_text
from gaitcap.services.bus.messages import (
    MAX_CALIBRATION_BYTES,
    MAX_FRAME_ID,
    MAX_JSON_BYTES,
    BoardView,
    BoardWatch,
    CameraScene,
    CameraStatus,
    ChunkReply,
    ChunkRequest,
    FrameMeta,
    ImageFrame,
    Keypoints,
    RecorderEvent,
    RecorderReply,
    RecorderStart,
    RecorderStop,
)
from gaitcap.services.nodes.recorder import confined_path
from gaitcap.services.processing.pipeline import ring_rig

CALIBRATION = rig_to_toml_text(ring_rig(2))
JPEG = bytes.fromhex("ffd8ffe000104a464946") + b"\x00" * 20 + bytes.fromhex("ffd9")


def _kp(**over):
    msg = {"camera": "cam01", "frame_id": 12, "timestamp_ns": 10**18, "skeleton": "halpe26",
           "people": [[[10.0, 20.0, 0.9]] * 26], "detector_ms": 3.5}
    msg.update(over)
    return json.dumps(msg).encode()


@pytest.mark.parametrize("message", [
    Keypoints("cam01", 3, 10**18, "halpe26", [[[1.0, 2.0, 0.5]] * 26, [[3.0, 4.0, 1.0]] * 26], 2.0),
    CameraStatus("cam01", "camera-0", "running", "ok", fps=29.9, frames=3, last_frame_id=2, time_ns=5,
                 extra={"serial": "123"}),
    RecorderStart("t-1", "t-1/recording.mcap", {"patient": "P1"}, CALIBRATION, ["cam0", "cam1"]),
    RecorderStop("t-1"),
    RecorderReply(ok=False, error="no"),
    RecorderEvent("stopped", "t-1", "/d/t.mcap", 7, summary={"frames": 3}),
    CameraScene("board", 5),
    FrameMeta(4, 10**18, ptp_jump=True),
    BoardWatch("C20261129-062238-594275", True, {"kind": "checkerboard", "squares": [8, 6], "square_mm": 100}),
    BoardView("C1", "cam01", 7, 10**18, 576, 360, [[1.5, 2.25], [-0.5, 359.5]]),
    ChunkRequest("T1", "T1.mcap", 1 << 20, 1 << 20),
    ChunkReply(offset=1 << 20, size=3 << 20),
    ChunkReply(error="trial T1: no finished recording T1.mcap here"),
])
def test_round_trip(message):
    assert type(message).from_bytes(message.to_bytes()) == message


@pytest.mark.parametrize("payload,match", [
    (_kp(frame_id=2**40), "keypoints.frame_id: 1099511627776 is not an integer"),
    (_kp(frame_id=-1), "keypoints.frame_id"),
    (_kp(frame_id=True), "keypoints.frame_id"),
    (_kp(people=[[[1.0, 2.0, 0.5]]] * (MAX_PEOPLE + 1)), "at most 32 people"),
    (_kp(people=[[[1.0, 2.0]]]), r"people\[0\]\[0\]: must be \[x px, y px, confidence\]"),
    (_kp(people=[[[1.0, 2.0, 0.5]] * 3, [[1.0, 2.0, 0.5]] * 2]), r"people\[1\]: 2 joints, person 0 has 3"),
    (_kp(people=[[[1.0, 2.0, 1.5]]]), "confidence"),
    (_kp(people=[[[1e9, 2.0, 0.5]]]), r"\.x"),
    (_kp(camera="../etc"), "keypoints.camera"),
    (_kp(extra=1), r"unknown fields \['extra'\]"),
    (_kp().replace(b"10.0", b"NaN"), "NaN is not allowed"),
    (_kp().replace(b"10.0", b"Infinity"), "Infinity is not allowed"),
    (b"[1]", "JSON object"),
    (b"\xff", "not JSON"),
    (b" " * (MAX_JSON_BYTES + 1), "exceeds"),
])
def test_keypoints_out_of_bounds_are_refused_naming_the_field(payload, match):
    with pytest.raises(ValueError, match=match):
        Keypoints.from_bytes(payload)


def test_the_bus_writes_the_keypoint_message_format_and_a_joint_not_seen_travels_as_zeros_not_nan():
    from gaitcap.acquisition.keypoint_message import parse_keypoint_message

    sent = Keypoints("cam01", 3, 10**18, "halpe26", [[[1.0, 2.0, 0.5], [0.0, 0.0, 0.0]]], 2.0)
    read = parse_keypoint_message(sent.to_bytes(), camera="cam01")
    assert (read.frame_id, read.timestamp_ns, read.skeleton, read.camera, read.detector_ms) == (3, 10**18, "halpe26",
                                                                                                 "cam01", 2.0)
    assert read.people.tolist() == sent.people
    with pytest.raises(ValueError, match=r"keypoints of camera cam01\.people\[0\]\[1\]\.x: not a finite number"):
        Keypoints("cam01", 3, 10**18, "halpe26", [[[1.0, 2.0, 0.5], [float("nan"), float("nan"), 0.0]]])
    with pytest.raises(ValueError, match=r"keypoints of camera cam01\.people\[0\]\[0\]\.y: beyond"):
        Keypoints("cam01", 3, 10**18, "halpe26", [[[1.0, 10**400, 0.5]]])  # a ValueError the recorder rejects
    with pytest.raises(ValueError, match=r"keypoints\.detector_ms: 1000.* is not a finite number in"):
        Keypoints("cam01", 3, 10**18, "halpe26", [], 10**400)


def test_one_timestamp_per_frame_and_the_camera_must_match_its_key():
    frame = ImageFrame.build(JPEG, camera="cam01", timestamp_ns=123_456_789_000, frame_id=7, sent_ns=10**18)
    att = frame.meta.to_bytes()
    assert "timestamp" not in json.loads(att)
    parsed = ImageFrame.from_bytes(frame.payload, att, camera="cam01")
    assert (parsed.timestamp_ns, parsed.frame_id, parsed.jpeg) == (123_456_789_000, 7, JPEG)
    with pytest.raises(ValueError, match="image on camera cam02's key names camera 'cam01'"):
        ImageFrame.from_bytes(frame.payload, att, camera="cam02")
    with pytest.raises(ValueError, match="no frame attachment"):
        ImageFrame.from_bytes(frame.payload, None, camera="cam01")
    with pytest.raises(ValueError, match="frame attachment.frame_id"):
        ImageFrame.from_bytes(frame.payload, json.dumps({"frame_id": 2**40, "sent_ns": 1}).encode(), camera="cam01")


def test_control_messages_are_bounded():
    with pytest.raises(ValueError, match="recorder start.trial_id"):
        RecorderStart.from_bytes(json.dumps({"trial_id": "a/../b", "path": "x.mcap"}).encode())
    with pytest.raises(ValueError, match="missing path"):
        RecorderStart("t1", "")
    with pytest.raises(ValueError, match="recorder start.cameras"):
        RecorderStart("t1", "t1.mcap", cameras=["ok", "not ok"])
    with pytest.raises(ValueError, match="camera scene.scene"):
        CameraScene.from_bytes(b'{"scene": "walls", "start_ns": 1}')
    assert MAX_FRAME_ID == 2**31 - 1
    with pytest.raises(ValueError, match="board watch.slot_s"):
        BoardWatch("C1", True, slot_s=0.0)
    with pytest.raises(ValueError, match="board watch.active"):
        BoardWatch.from_bytes(b'{"calibration_id": "C1", "active": 1}')
    with pytest.raises(ValueError, match="board view.width_px"):
        BoardView("C1", "cam01", 7, 1, 0, 360)
    with pytest.raises(ValueError, match=r"board view.corners: every row must be \[x, y\]"):
        BoardView("C1", "cam01", 7, 1, 576, 360, [[1.0, 2.0, 3.0]])
    with pytest.raises(ValueError, match="board view.corners"):
        BoardView.from_bytes(b'{"calibration_id": "C1", "camera": "cam01", "frame_id": 1, "timestamp_ns": 1, '
                             b'"width_px": 5, "height_px": 5, "corners": [[1e999, 2]]}')
    with pytest.raises(ValueError, match="recording chunk request.name: 'T1.mcap.part' is not an .mcap file name"):
        ChunkRequest("T1", "T1.mcap.part", 0, 1)
    with pytest.raises(ValueError, match="recording chunk request.name"):
        ChunkRequest("T1", "../T1.mcap", 0, 1)
    with pytest.raises(ValueError, match="recording chunk request.length"):
        ChunkRequest("T1", "T1.mcap", 0, (8 << 20) + 1)
    with pytest.raises(ValueError, match="recording chunk reply.transient"):
        ChunkReply.from_bytes(b'{"error": "x", "transient": 1}')


def test_the_calibration_travels_as_its_own_field():
    start = RecorderStart("t-1", "t-1/recording.mcap", {"patient": "P1"}, calibration_toml=CALIBRATION)
    back = RecorderStart.from_bytes(start.to_bytes())
    assert back.calibration_toml == CALIBRATION and back.metadata == {"patient": "P1"}
    assert rig_from_toml_text(back.calibration_toml).names == ["cam0", "cam1"]
    assert RecorderStart("t-1", "t-1.mcap").calibration_toml is None


@pytest.mark.parametrize("value,match", [
    ("", "must be a calibration TOML of 1 to"),
    (42, "must be a calibration TOML of 1 to"),
    ("#" * (MAX_CALIBRATION_BYTES + 1), "must be a calibration TOML of 1 to"),
    ("[cam_0\n", "not valid TOML"),
    ("title = 'no cameras'\n", "no camera sections"),
])
def test_a_bad_calibration_is_refused_naming_the_field(value, match):
    payload = json.dumps({"trial_id": "t1", "path": "t1.mcap", "calibration_toml": value}).encode()
    with pytest.raises(ValueError, match=f"recorder start.calibration_toml.*{match}"):
        RecorderStart.from_bytes(payload)


def test_recorder_paths_are_confined_to_the_data_folder(tmp_path):
    root = tmp_path / "data"
    (root / "t1").mkdir(parents=True)
    assert confined_path(root, "t1/recording.mcap") == (root / "t1" / "recording.mcap").resolve()
    assert confined_path(root, str(root / "t1" / "r.mcap")) == (root / "t1" / "r.mcap").resolve()
    os.symlink(tmp_path, root / "out")
    for bad in ("../evil.mcap", str(tmp_path / "evil.mcap"), "/etc/evil.mcap", "out/evil.mcap", "t1/../../x.mcap"):
        with pytest.raises(ValueError, match="outside the recorder's data folder"):
            confined_path(root, bad)
    with pytest.raises(ValueError, match="must end with .mcap"):
        confined_path(root, "t1/notes.txt")
