"""The layout of a gaitcap trial MCAP (one file per trial).

Topics (MCAP channels):

============================  =========  ================================  =========================
topic                         encoding   schema                            log_time / sequence
============================  =========  ================================  =========================
``/camera/<cam>/image``       protobuf   ``foxglove.CompressedImage``      camera timestamp ns / frame id
``/camera/<cam>/annotations`` protobuf   ``foxglove.ImageAnnotations``     camera timestamp ns / frame id
``/camera/<cam>/calibration`` protobuf   ``foxglove.CameraCalibration``    trial start
``/camera/<cam>/status``      json       ``gaitcap.CameraStatus``          receive time ns
``/keypoints/<cam>``          json       ``gaitcap.Keypoints2D``           camera timestamp ns / frame id
``/trial/metadata``           json       ``gaitcap.TrialMetadata``         trial start
``/trial/calibration``        json       ``gaitcap.Calibration``           trial start
============================  =========  ================================  =========================

The annotations (keypoints drawn: points coloured by confidence, bones, person labels) and the camera
calibrations are Foxglove's own types (:mod:`.foxglove_messages`), so Foxglove's Image panel shows
each camera's video with its overlay without configuration; the keypoint channel keeps full precision.
An annotation has the log time and ``timestamp`` of the image it belongs to.

Keypoint messages are buffered and written in chunks of their own (never mixed with images), so a
reader that asks only for ``/keypoints/*`` skips every image chunk through the chunk index.

MCAP records besides messages: metadata ``trial`` (the trial metadata, values JSON-encoded strings),
attachment ``calibration.toml`` (aniposelib TOML) when a calibration was given, and metadata
``summary`` (frame counts, gaps per camera, error) written at the end. The trial metadata and calibration
are ALSO written as the first messages so that a file cut short by a crash still carries them.

While recording, the file is ``<path>.part``; a clean stop renames it to ``<path>``. A recorder that
died leaves ``<path>.part``; :func:`gaitcap.acquisition.recording.recovery.recover` reads every complete chunk.
"""

from __future__ import annotations

import json

PART_SUFFIX = ".part"
PROFILE = "gaitcap"

TRIAL_METADATA_TOPIC = "/trial/metadata"
CALIBRATION_TOPIC = "/trial/calibration"
CALIBRATION_ATTACHMENT = "calibration.toml"
TRIAL_METADATA_RECORD = "trial"
SUMMARY_RECORD = "summary"


def image_topic(camera: str) -> str:
    return f"/camera/{camera}/image"


def status_topic(camera: str) -> str:
    return f"/camera/{camera}/status"


def keypoints_topic(camera: str) -> str:
    return f"/keypoints/{camera}"


def annotations_topic(camera: str) -> str:
    return f"/camera/{camera}/annotations"


def camera_calibration_topic(camera: str) -> str:
    return f"/camera/{camera}/calibration"


def camera_of_topic(topic: str) -> str:
    """The camera name in an image, status or keypoints topic."""
    parts = topic.strip("/").split("/")
    if len(parts) >= 2 and parts[0] in ("camera", "keypoints"):
        return parts[1]
    raise ValueError(f"topic {topic!r} names no camera")


def is_image_topic(topic: str) -> bool:
    return topic.startswith("/camera/") and topic.endswith("/image")


def is_keypoints_topic(topic: str) -> bool:
    return topic.startswith("/keypoints/")


def is_status_topic(topic: str) -> bool:
    return topic.startswith("/camera/") and topic.endswith("/status")


_JSON_SCHEMAS = {
    "gaitcap.Keypoints2D": {
        "type": "object",
        "description": "2D keypoints of the people one camera saw in one frame",
        "properties": {
            "camera": {"type": "string"},
            "frame_id": {"type": "integer"},
            "timestamp_ns": {"type": "integer", "description": "camera timestamp, ns"},
            "skeleton": {"type": "string", "description": "e.g. halpe26, mediapipe33"},
            "people": {
                "type": "array",
                "description": "P people, each J x [x px, y px, confidence 0..1]; people[0] is the patient",
                "items": {"type": "array", "items": {"type": "array", "items": {"type": "number"}}},
            },
        },
        "required": ["camera", "frame_id", "timestamp_ns", "skeleton", "people"],
    },
    "gaitcap.CameraStatus": {
        "type": "object",
        "properties": {
            "camera": {"type": "string"},
            "health": {"type": "string"},
            "fps": {"type": "number"},
            "frames": {"type": "integer"},
            "drops": {"type": "integer"},
            "last_timestamp_ns": {"type": ["integer", "null"]},
        },
    },
    "gaitcap.TrialMetadata": {"type": "object", "description": "free-form trial metadata"},
    "gaitcap.Calibration": {
        "type": "object",
        "properties": {"format": {"type": "string"}, "toml": {"type": "string"}},
    },
}


def json_schema(name: str) -> bytes:
    """The JSON schema (bytes) registered for a JSON channel."""
    return json.dumps({"title": name, **_JSON_SCHEMAS[name]}).encode()


_PROTOBUF_SUFFIXES = {
    "/image": "foxglove.CompressedImage",
    "/annotations": "foxglove.ImageAnnotations",
    "/calibration": "foxglove.CameraCalibration",
}


def protobuf_schema_of_topic(topic: str) -> str | None:
    """The Foxglove protobuf schema of a ``/camera/<cam>/...`` topic, None for a JSON topic."""
    if topic.startswith("/camera/"):
        for suffix, name in _PROTOBUF_SUFFIXES.items():
            if topic.endswith(suffix):
                return name
    return None


def schema_of_topic(topic: str) -> str:
    """The JSON schema name used on a JSON topic (see :func:`protobuf_schema_of_topic` for the others)."""
    if is_keypoints_topic(topic):
        return "gaitcap.Keypoints2D"
    if is_status_topic(topic):
        return "gaitcap.CameraStatus"
    fixed = {
        TRIAL_METADATA_TOPIC: "gaitcap.TrialMetadata",
        CALIBRATION_TOPIC: "gaitcap.Calibration",
    }
    if topic not in fixed:
        raise ValueError(f"topic {topic!r} is not part of the trial layout")
    return fixed[topic]
