"""Foxglove's own message types (protobuf) built from gaitcap data, so Foxglove draws them unconfigured.

- :func:`image_annotations`: one camera's 2D keypoints of one frame as ``foxglove.ImageAnnotations``
  (keypoints as points coloured by confidence, the skeleton's bones as a line list per person, each
  person's index as text above the head). Its ``timestamp`` is the frame's camera timestamp, the same
  as the image's, which is how the Image panel pairs the two.
- :func:`camera_calibration`: a :class:`~gaitcap.reconstruction.camera.Camera` as
  ``foxglove.CameraCalibration`` (K, plumb-bob distortion, size in px, ``frame_id`` = camera name,
  the ``frame_id`` of its images).
- :func:`schema_data`: the serialised FileDescriptorSet registered as an MCAP schema for any of them.

Colours: confidence 0 is red, 1 is green (linear in between); bones take the lower confidence of
their two joints. A joint with confidence <= 0 or a non-finite coordinate is not drawn.
"""

from __future__ import annotations

from functools import cache, lru_cache
from typing import Any

import numpy as np
from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
from foxglove_schemas_protobuf.Color_pb2 import Color
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from foxglove_schemas_protobuf.ImageAnnotations_pb2 import ImageAnnotations
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.Point2_pb2 import Point2
from foxglove_schemas_protobuf.PointsAnnotation_pb2 import PointsAnnotation
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from gaitcap.reconstruction.camera import Camera
from gaitcap.reconstruction.skeletons import get_skeleton

# schema name -> protobuf class, for every Foxglove type gaitcap writes
PROTOBUF_TYPES = {cls.DESCRIPTOR.full_name: cls for cls in (
    CompressedImage, ImageAnnotations, CameraCalibration, SceneUpdate, FrameTransform, Log)}

POINT_DIAMETER_PX = 6.0
BONE_THICKNESS_PX = 2.0
TEXT_SIZE_PX = 14.0
TEXT_OFFSET_PX = 20.0


@cache
def schema_data(name: str) -> bytes:
    """The serialised FileDescriptorSet of Foxglove type ``name`` (the MCAP schema data)."""
    from mcap_protobuf.schema import build_file_descriptor_set

    if name not in PROTOBUF_TYPES:
        raise ValueError(f"schema: {name!r} is not one of {sorted(PROTOBUF_TYPES)}")
    return build_file_descriptor_set(PROTOBUF_TYPES[name]).SerializeToString()


def set_time(stamp, time_ns: int) -> None:
    """Fill a ``google.protobuf.Timestamp`` from ns."""
    stamp.seconds, stamp.nanos = divmod(int(time_ns), 1_000_000_000)


def confidence_rgba(confidence: np.ndarray) -> np.ndarray:
    """(N,) confidence 0..1 -> (N, 4) RGBA 0..1, red (0) to green (1), opaque."""
    c = np.clip(np.nan_to_num(np.asarray(confidence, dtype=np.float64)), 0.0, 1.0)
    return np.stack([1.0 - c, c, np.full_like(c, 0.2), np.ones_like(c)], axis=-1)


@lru_cache(maxsize=16)
def _bones(skeleton: str) -> np.ndarray:
    """(B, 2) joint indices of the bones to draw for a skeleton name."""
    return np.asarray(get_skeleton(skeleton).bone_indices, dtype=np.int64).reshape(-1, 2)


def _colors(rgba: np.ndarray) -> list[Color]:
    return [Color(r=r, g=g, b=b, a=a) for r, g, b, a in rgba.tolist()]


def _person(annotations: ImageAnnotations, person: np.ndarray, index: int, bones: np.ndarray,
            time_ns: int) -> None:
    """Points, bones and a label for one person, (J, 3) x px, y px, confidence."""
    shown = np.isfinite(person).all(axis=1) & (person[:, 2] > 0)
    if not shown.any():
        return
    xy = person[:, :2]
    points = annotations.points.add(type=PointsAnnotation.POINTS, thickness=POINT_DIAMETER_PX)
    set_time(points.timestamp, time_ns)
    points.points.extend(Point2(x=x, y=y) for x, y in xy[shown].tolist())
    points.outline_colors.extend(_colors(confidence_rgba(person[shown, 2])))
    if bones.size:
        keep = bones[shown[bones].all(axis=1)]
        if keep.size:
            lines = annotations.points.add(type=PointsAnnotation.LINE_LIST, thickness=BONE_THICKNESS_PX)
            set_time(lines.timestamp, time_ns)
            lines.points.extend(Point2(x=x, y=y) for x, y in xy[keep.reshape(-1)].tolist())
            conf = np.minimum(person[keep[:, 0], 2], person[keep[:, 1], 2])
            lines.outline_colors.extend(_colors(np.repeat(confidence_rgba(conf), 2, axis=0)))
    top = int(np.argmin(np.where(shown, xy[:, 1], np.inf)))
    text = annotations.texts.add(text=f"person {index}", font_size=TEXT_SIZE_PX,
                                 text_color=Color(r=1, g=1, b=1, a=1),
                                 background_color=Color(r=0, g=0, b=0, a=0.6))
    set_time(text.timestamp, time_ns)
    text.position.x, text.position.y = float(xy[top, 0]), float(xy[top, 1]) - TEXT_OFFSET_PX


def image_annotations(keypoints: dict[str, Any]) -> bytes:
    """A ``gaitcap.Keypoints2D`` message (dict) -> serialised ``foxglove.ImageAnnotations``.

    ``people[p]`` is (J, 3) x px, y px, confidence; person ``p`` is labelled ``person p``.
    ValueError naming the camera and field when the message is malformed.
    """
    camera = keypoints.get("camera", "?")
    try:
        time_ns, skeleton = int(keypoints["timestamp_ns"]), str(keypoints["skeleton"])
        people = [np.asarray(p, dtype=np.float64) for p in keypoints["people"]]
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"keypoints of camera {camera}: malformed message ({exc!r})") from None
    bones = _bones(skeleton)
    annotations = ImageAnnotations()
    for index, person in enumerate(people):
        if person.ndim != 2 or person.shape[1] != 3:
            raise ValueError(f"keypoints of camera {camera}: people[{index}] must be J x 3, got {person.shape}")
        if bones.size and bones.max() >= person.shape[0]:
            raise ValueError(f"keypoints of camera {camera}: people[{index}] has {person.shape[0]} joints, "
                             f"skeleton {skeleton} needs {bones.max() + 1}")
        _person(annotations, person, index, bones, time_ns)
    return annotations.SerializeToString()


def camera_calibration(camera: Camera, *, time_ns: int) -> bytes:
    """A rig camera -> serialised ``foxglove.CameraCalibration`` (plumb_bob: k1, k2, p1, p2, k3)."""
    k = camera.matrix_px
    msg = CameraCalibration(frame_id=camera.name, width=camera.size_px[0], height=camera.size_px[1],
                            distortion_model="plumb_bob", D=camera.dist.tolist(), K=k.reshape(-1).tolist(),
                            R=np.eye(3).reshape(-1).tolist(),
                            P=np.hstack([k, np.zeros((3, 1))]).reshape(-1).tolist())
    set_time(msg.timestamp, time_ns)
    return msg.SerializeToString()
