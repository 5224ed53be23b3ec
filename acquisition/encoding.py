"""JPEG encoding and the ``foxglove.CompressedImage`` protobuf that carries frames on the bus and in MCAP.

A frame on the wire is a serialised ``foxglove.CompressedImage``:
``timestamp`` = camera timestamp (s + ns), ``frame_id`` = camera name (Foxglove's coordinate frame),
``format`` = "jpeg", ``data`` = the JPEG bytes. Recordings made of these open directly in Foxglove.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage

IMAGE_SCHEMA_NAME = "foxglove.CompressedImage"
JPEG_MAGIC = b"\xff\xd8"


def encode_jpeg(image: np.ndarray, *, quality: int = 90) -> bytes:
    """(H, W, 3) uint8 BGR or (H, W) grey image -> JPEG bytes."""
    img = np.asarray(image)
    if img.dtype != np.uint8 or img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[2] not in (1, 3)):
        raise ValueError(f"image: expected (H, W, 3) or (H, W) uint8, got {img.shape} {img.dtype}")
    if not 1 <= quality <= 100:
        raise ValueError(f"quality: JPEG quality must be in 1..100, got {quality}")
    ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise ValueError(f"image: OpenCV could not encode a {img.shape} image as JPEG")
    return buf.tobytes()


def decode_jpeg(data: bytes, *, what: str = "frame") -> np.ndarray:
    """JPEG bytes -> (H, W, 3) uint8 BGR; ValueError naming ``what`` when the bytes are not a JPEG."""
    if not data or data[:2] != JPEG_MAGIC:
        raise ValueError(f"{what}: not JPEG data ({len(data)} bytes)")
    img = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_COLOR)
    if img is None:
        raise ValueError(f"{what}: corrupt JPEG data ({len(data)} bytes)")
    return img


@dataclass(frozen=True)
class ImageMessage:
    """A decoded ``foxglove.CompressedImage`` (JPEG still compressed).

    Attributes:
        camera: the camera name (the message's ``frame_id``).
        timestamp_ns: camera timestamp in ns.
        jpeg: the JPEG bytes.
    """

    camera: str
    timestamp_ns: int
    jpeg: bytes

    def image(self) -> np.ndarray:
        return decode_jpeg(self.jpeg, what=f"camera {self.camera} frame at {self.timestamp_ns} ns")


def image_message(jpeg: bytes, *, camera: str, timestamp_ns: int) -> bytes:
    """Serialise a ``foxglove.CompressedImage`` for one JPEG frame."""
    msg = CompressedImage(frame_id=camera, data=jpeg, format="jpeg")
    msg.timestamp.seconds = int(timestamp_ns) // 1_000_000_000
    msg.timestamp.nanos = int(timestamp_ns) % 1_000_000_000
    return msg.SerializeToString()


def parse_image_message(data: bytes) -> ImageMessage:
    """Bytes of a ``foxglove.CompressedImage`` -> :class:`ImageMessage`; ValueError when unreadable."""
    msg = CompressedImage()
    try:
        msg.ParseFromString(bytes(data))
    except Exception as exc:  # protobuf's DecodeError
        raise ValueError(f"image message: not a foxglove.CompressedImage ({exc})") from None
    if msg.format and msg.format.lower() not in ("jpeg", "jpg"):
        raise ValueError(f"image message from camera {msg.frame_id}: format {msg.format!r}, expected jpeg")
    ts = msg.timestamp.seconds * 1_000_000_000 + msg.timestamp.nanos
    return ImageMessage(camera=msg.frame_id, timestamp_ns=int(ts), jpeg=msg.data)


def image_schema_data() -> bytes:
    """The serialised FileDescriptorSet of ``foxglove.CompressedImage`` (the MCAP schema data)."""
    from gaitcap.acquisition.recording.foxglove_messages import schema_data

    return schema_data(IMAGE_SCHEMA_NAME)
