"""The trial MCAP's Foxglove types, read back with the official readers (mcap + mcap-protobuf-support
decoding into foxglove-schemas-protobuf classes): schema names, frame ids, monotonic log times per
channel, and annotations that line up with their image."""

import json

import numpy as np
import pytest
from gaitcap.acquisition.encoding import encode_jpeg, image_message
from gaitcap.acquisition.recording.foxglove_messages import camera_calibration, image_annotations
from gaitcap.acquisition.recording.writer import TrialWriter
from gaitcap.reconstruction.calibration_io import rig_to_toml_text
from gaitcap.reconstruction.skeletons import get_skeleton
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory
from recording_helpers import CAMS, FRAMES, PERIOD_NS, T0_NS, people_for, tiny_rig

BONES = len(get_skeleton("halpe26").bones)


def _write_with_annotations(path):
    """The recorder's writes for CAMS x FRAMES: frame, keypoints and their annotations (keypoints of
    camera 0 arrive one frame late, as a detector's would)."""
    w = TrialWriter(path)
    w.start(metadata={"trial_id": "t"}, calibration_toml=rig_to_toml_text(tiny_rig()), time_ns=T0_NS - 5)
    late = None
    for f in range(FRAMES):
        for c, cam in enumerate(CAMS):
            ts = T0_NS + f * PERIOD_NS + 1000 * c
            jpeg = encode_jpeg(np.full((48, 64, 3), f * 10 % 255, np.uint8))
            w.add_frame(cam, image_message(jpeg, camera=cam, timestamp_ns=ts), timestamp_ns=ts, frame_id=f,
                        receive_ns=ts + 1)
            people = people_for(c, f)
            people[0, 3, 2] = 0.0  # one joint not seen: not drawn
            msg = {"camera": cam, "frame_id": f, "timestamp_ns": ts, "skeleton": "halpe26",
                   "people": people.tolist()}
            if c == 0:
                late, msg = msg, late
            if msg is not None:
                w.add_keypoints(msg["camera"], json.dumps(msg).encode(), timestamp_ns=msg["timestamp_ns"],
                                frame_id=msg["frame_id"])
                w.add_annotations(msg["camera"], image_annotations(msg), timestamp_ns=msg["timestamp_ns"],
                                  frame_id=msg["frame_id"])
    return w.finish({})


def _decoded(path):
    """topic -> [(schema name, log time ns, decoded message)] in file order."""
    out = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        topics = [c.topic for c in reader.get_summary().channels.values() if c.message_encoding == "protobuf"]
        for schema, channel, message, decoded in reader.iter_decoded_messages(topics, log_time_order=False):
            out.setdefault(channel.topic, []).append((schema.name, message.log_time, decoded))
    return out


def _ns(stamp) -> int:
    return stamp.seconds * 1_000_000_000 + stamp.nanos


def test_images_annotations_and_calibrations_read_back_with_the_official_readers(tmp_path):
    decoded = _decoded(_write_with_annotations(tmp_path / "t.mcap"))
    rig = tiny_rig()
    for c, cam in enumerate(CAMS):
        images = decoded[f"/camera/{cam}/image"]
        notes = decoded[f"/camera/{cam}/annotations"]
        (calibration,) = decoded[f"/camera/{cam}/calibration"]
        assert {s for s, _, _ in images} == {"foxglove.CompressedImage"}
        assert {s for s, _, _ in notes} == {"foxglove.ImageAnnotations"}
        assert calibration[0] == "foxglove.CameraCalibration"
        k = calibration[2]
        assert k.frame_id == cam == images[0][2].frame_id
        assert (k.width, k.height) == rig[cam].size_px and k.distortion_model == "plumb_bob"
        np.testing.assert_allclose(np.reshape(k.K, (3, 3)), rig[cam].matrix_px)
        assert calibration[1] < images[0][1]  # the calibration is there before the first image
        for series in (images, notes):
            times = [t for _, t, _ in series]
            assert times == sorted(times)
        frames = {t: m for _, t, m in images}
        assert len(notes) == FRAMES - (c == 0)  # camera 0's last keypoints never arrived
        for n, (_, t, note) in enumerate(notes):
            assert t in frames and all(_ns(p.timestamp) == _ns(frames[t].timestamp) == t for p in note.points)
            assert len(note.points) == 4  # two people: points and bones each
            points, bones = note.points[:2]
            want = people_for(c, n)[0]
            shown = np.ones(len(want), bool)
            shown[3] = False
            got = np.array([[p.x, p.y] for p in points.points])
            np.testing.assert_allclose(got, want[shown, :2])
            assert len(points.outline_colors) == shown.sum() and points.outline_colors[0].g == pytest.approx(0.9, abs=0.5 / 32)  # 32 colour steps
            bones_without_joint_3 = sum(3 not in b for b in get_skeleton("halpe26").bone_indices)
            assert len(bones.points) == 2 * bones_without_joint_3 < 2 * BONES
            assert [t.text for t in note.texts] == ["person 0", "person 1"]


def test_confidence_colours_run_from_red_to_green():
    people = np.zeros((1, 26, 3))
    people[0, :, 0], people[0, :, 1] = np.arange(26), 10.0
    people[0, :, 2] = np.linspace(0.0, 1.0, 26)
    from foxglove_schemas_protobuf.ImageAnnotations_pb2 import ImageAnnotations

    note = ImageAnnotations.FromString(image_annotations(
        {"camera": "c", "timestamp_ns": 5, "skeleton": "halpe26", "people": people.tolist()}))
    colours = note.points[0].outline_colors
    assert len(colours) == 25  # confidence 0 is not drawn
    assert colours[-1].g == pytest.approx(1.0) and colours[-1].r == pytest.approx(0.0)
    assert colours[0].r > colours[-1].r and colours[0].g < colours[-1].g


@pytest.mark.parametrize(("message", "match"), [
    ({"camera": "cam7", "skeleton": "halpe26", "people": []}, "camera cam7: malformed"),
    ({"camera": "cam7", "timestamp_ns": 1, "skeleton": "halpe26", "people": [[[1, 2]] * 26]},
     r"camera cam7: people\[0\] must be J x 3"),
    ({"camera": "cam7", "timestamp_ns": 1, "skeleton": "halpe26", "people": [[[1, 2, 1]] * 5]},
     "camera cam7: people.0. has 5 joints"),
    ({"camera": "cam7", "timestamp_ns": 1, "skeleton": "nope", "people": []}, "unknown skeleton"),
])
def test_bad_keypoints_name_the_camera_and_field(message, match):
    with pytest.raises(ValueError, match=match):
        image_annotations(message)


def test_a_calibration_that_is_not_a_rig_is_refused_at_start(tmp_path):
    w = TrialWriter(tmp_path / "t.mcap")
    with pytest.raises(ValueError, match="calibration"):
        w.start(metadata={}, calibration_toml="[cam_0]\nname = 'x'\n", time_ns=1)
    w.abort()
    assert camera_calibration(tiny_rig()[0], time_ns=3)  # a good camera serialises


def test_a_typed_message_draws_like_its_dict():
    from types import SimpleNamespace

    msg = {"camera": "cam0", "timestamp_ns": 7, "skeleton": "halpe26", "people": people_for(0, 3).tolist()}
    assert image_annotations(SimpleNamespace(**msg)) == image_annotations(msg)
