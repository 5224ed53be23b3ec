import numpy as np
import pytest
from gaitcap.acquisition.encoding import (
    decode_jpeg,
    encode_jpeg,
    image_message,
    image_schema_data,
    parse_image_message,
)


def test_round_trip_through_compressed_image():
    rng = np.random.default_rng(1)
    img = (rng.integers(0, 40, (48, 64, 3)) + 100).astype(np.uint8)
    jpeg = encode_jpeg(img, quality=95)
    data = image_message(jpeg, camera="cam07", timestamp_ns=1_700_000_000_123_456_789)
    msg = parse_image_message(data)
    assert msg.camera == "cam07" and msg.timestamp_ns == 1_700_000_000_123_456_789 and msg.jpeg == jpeg
    assert np.abs(msg.image().astype(int) - img).mean() < 8


def test_foxglove_schema_is_a_descriptor_set():
    from google.protobuf.descriptor_pb2 import FileDescriptorSet

    fds = FileDescriptorSet.FromString(image_schema_data())
    assert any(m.name == "CompressedImage" for f in fds.file for m in f.message_type)


def test_bad_inputs_are_named():
    with pytest.raises(ValueError, match="uint8"):
        encode_jpeg(np.zeros((4, 4, 3), np.float32))
    with pytest.raises(ValueError, match="cam3"):
        decode_jpeg(b"\xff\xd8garbage", what="cam3")
    with pytest.raises(ValueError, match="not JPEG"):
        decode_jpeg(b"PNG")
    with pytest.raises(ValueError, match="foxglove"):
        parse_image_message(b"\xff\xff\xff")
