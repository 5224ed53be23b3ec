"""Foxglove's own message types (protobuf) built from gaitcap data, so Foxglove draws them unconfigured.

- :func:`image_annotations`: one camera's 2D keypoints of one frame as ``foxglove.ImageAnnotations``
  (keypoints as points coloured by confidence, the skeleton's bones as a line list per person, each
  person's index as text above the head). Its ``timestamp`` is the frame's camera timestamp, the same
  as the image's, which is how the Image panel pairs the two.
- :func:`camera_calibration`: a :class:`~gaitcap.reconstruction.camera.Camera` as
  ``foxglove.CameraCalibration`` (K, plumb-bob distortion, size in px, ``frame_id`` = camera name,
  the ``frame_id`` of its images).
- :func:`schema_data`: the serialised FileDescriptorSet registered as an MCAP schema for any of them.

Colours: a joint's confidence 0 is red, 1 is green (linear in between, in 32 steps); bones are light
grey. A joint with confidence <= 0 or a non-finite coordinate is not drawn, nor its bones.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from functools import cache, lru_cache
from typing import Any

import numpy as np
from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
from foxglove_schemas_protobuf.Color_pb2 import Color
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from foxglove_schemas_protobuf.ImageAnnotations_pb2 import ImageAnnotations
from foxglove_schemas_protobuf.Log_pb2 import Log
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
def _bones(skeleton: str) -> tuple[tuple[int, int], ...]:
    """Joint index pairs of the bones to draw for a skeleton name."""
    return tuple(get_skeleton(skeleton).bone_indices)


# Confidence colours in COLOR_LEVELS steps, made once. The live path fills repeated fields from plain
# dicts: protobuf builds those about 3x faster than from message objects.
COLOR_LEVELS = 32
_LEVELS = tuple({"r": r, "g": g, "b": b, "a": a} for r, g, b, a in
                confidence_rgba(np.linspace(0.0, 1.0, COLOR_LEVELS + 1)).tolist())
_TEXT, _TEXT_BACKGROUND = Color(r=1, g=1, b=1, a=1), Color(r=0, g=0, b=0, a=0.6)
_BONE = Color(r=0.95, g=0.95, b=0.95, a=0.9)


def _level(confidence: float) -> dict[str, float]:
    """The colour of a confidence > 0 (above 1 counts as 1)."""
    return _LEVELS[min(int(confidence * COLOR_LEVELS + 0.5), COLOR_LEVELS)]


def _joints(person, *, camera: str, index: int) -> list[tuple[float, float, float] | None]:
    """(x px, y px, confidence) per joint, None where not seen (confidence <= 0 or not finite)."""
    try:
        joints = [(float(x), float(y), float(c)) for x, y, c in person]
    except (TypeError, ValueError) as exc:
        raise ValueError(f"keypoints of camera {camera}: people[{index}] must be J x 3 numbers ({exc})") from None
    return [j if j[2] > 0 and math.isfinite(j[0] + j[1] + j[2]) else None for j in joints]


def _person(annotations: ImageAnnotations, joints, index: int, bones, time_ns: int) -> None:
    """Points, bones and a label for one person (see :func:`_joints`)."""
    shown = [j for j in joints if j is not None]
    if not shown:
        return
    points = annotations.points.add(type=PointsAnnotation.POINTS, thickness=POINT_DIAMETER_PX,
                                    points=[{"x": x, "y": y} for x, y, _ in shown],
                                    outline_colors=[_level(c) for _, _, c in shown])
    set_time(points.timestamp, time_ns)
    ends = [j for a, b in bones if joints[a] is not None and joints[b] is not None for j in (joints[a], joints[b])]
    if ends:
        lines = annotations.points.add(type=PointsAnnotation.LINE_LIST, thickness=BONE_THICKNESS_PX,
                                       outline_color=_BONE, points=[{"x": x, "y": y} for x, y, _ in ends])
        set_time(lines.timestamp, time_ns)
    top = min(shown, key=lambda j: j[1])
    text = annotations.texts.add(text=f"person {index}", font_size=TEXT_SIZE_PX, text_color=_TEXT,
                                 background_color=_TEXT_BACKGROUND)
    set_time(text.timestamp, time_ns)
    text.position.x, text.position.y = top[0], top[1] - TEXT_OFFSET_PX


def image_annotations(keypoints: Mapping[str, Any] | Any) -> bytes:
    """A keypoint message -> serialised ``foxglove.ImageAnnotations``.

    ``keypoints``: a ``gaitcap.Keypoints2D`` dict, or any object with the same fields as attributes
    (``camera``, ``timestamp_ns`` ns, ``skeleton``, ``people``: P lists of J [x px, y px, confidence]).
    Person ``p`` is labelled ``person p``. ValueError naming the camera and field when malformed.
    """
    get = keypoints.get if isinstance(keypoints, Mapping) else lambda name, *default: getattr(keypoints, name, *default)
    camera = get("camera", "?")
    try:
        time_ns, skeleton, people = int(get("timestamp_ns")), str(get("skeleton")), get("people")
    except (AttributeError, KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"keypoints of camera {camera}: malformed message ({exc!r})") from None
    bones = _bones(skeleton)
    needed = 1 + max((max(b) for b in bones), default=-1)
    annotations = ImageAnnotations()
    for index, person in enumerate(people):
        joints = _joints(person, camera=camera, index=index)
        if len(joints) < needed:
            raise ValueError(f"keypoints of camera {camera}: people[{index}] has {len(joints)} joints, "
                             f"skeleton {skeleton} needs {needed}")
        _person(annotations, joints, index, bones, time_ns)
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
