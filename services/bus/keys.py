"""Every Zenoh key expression and message schema of gaitcap (the one place that documents them).

All keys live under a rig prefix (default ``gaitcap/default``; one prefix per rig so several rigs can
share a network). ``<cam>`` is a camera name as in the calibration, ``<node>`` a node name.

=====================================  ==========  ========================================================
key expression                         kind        payload
=====================================  ==========  ========================================================
``<prefix>/camera/<cam>/image``        put         protobuf ``foxglove.CompressedImage`` (JPEG; ``timestamp``
                                                   = camera timestamp, ``frame_id`` = camera name) with a
                                                   JSON attachment :data:`FRAME_ATTACHMENT` fields
``<prefix>/camera/<cam>/status``       put         JSON :data:`CAMERA_STATUS` (about once per second and on
                                                   every state change)
``<prefix>/keypoints/<cam>``           put         JSON :data:`KEYPOINTS` (one message per frame and camera)
``<prefix>/recorder/start``            queryable   query payload JSON :data:`RECORDER_START`; reply JSON
                                                   :data:`RECORDER_REPLY` (``ok`` false + ``error`` on refusal)
``<prefix>/recorder/stop``             queryable   query payload JSON ``{"trial_id": str}``; reply JSON
                                                   :data:`RECORDER_REPLY` with the trial summary
``<prefix>/recorder/status``           queryable   reply JSON ``{"recording": bool, "trial_id", "path"}``
``<prefix>/recorder/events``           put         JSON :data:`RECORDER_EVENT`
``<prefix>/alive/<node>``              liveliness  token held by every node while it runs
``<prefix>/worker/progress/<trial>``   put         JSON worker progress of one trial (``gaitcap.services.live.bus_link``)
``<prefix>/camera/scene``              put         JSON :data:`CAMERA_SCENE`: what simulated cameras show
=====================================  ==========  ========================================================

Wildcards: ``<prefix>/camera/*/image`` (all frames), ``<prefix>/keypoints/*``, ``<prefix>/alive/**``.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from typing import Any

DEFAULT_PREFIX = "gaitcap/default"
_NAME = re.compile(r"^[A-Za-z0-9_.\-]+$")

#: JSON attachment of every image put (Zenoh attachment, not part of the protobuf).
FRAME_ATTACHMENT = {
    "frame_id": "int, frame counter from the synchronised start (gaps = dropped frames)",
    "timestamp_ns": "int, camera timestamp (same as the protobuf's timestamp)",
    "sent_ns": "int, wall clock (time.time_ns) when the node published it: bus latency",
    "ptp_jump": "bool, the interval to the previous frame differs from the period by > 10x",
}

#: Camera status (also recorded in the MCAP as /camera/<cam>/status).
CAMERA_STATUS = {
    "camera": "str",
    "node": "str, the camera node publishing it",
    "state": "closed | open | configured | running | stopped | error",
    "health": "ok | stopped | error | ...",
    "fps": "float, delivered frames/s since start",
    "frames": "int, frames delivered",
    "drops": "int, frame-id gaps",
    "last_timestamp_ns": "int | null",
    "last_frame_id": "int | null",
    "ptp_jumps": "int",
    "error": "str | null",
    "time_ns": "int, wall clock when sent",
}

#: 2D keypoints of one frame of one camera (several people allowed; people[0] is the patient).
KEYPOINTS = {
    "camera": "str",
    "frame_id": "int",
    "timestamp_ns": "int, camera timestamp of the frame",
    "skeleton": "str, e.g. halpe26 or mediapipe33 (gaitcap.reconstruction.skeletons)",
    "people": "list of P people, each J lists [x px, y px, confidence 0..1]",
    "detector_ms": "float, time spent detecting",
}

#: Start a trial recording.
RECORDER_START = {
    "trial_id": "str",
    "path": "str, output .mcap on the recorder's host (must not exist)",
    "metadata": "dict, free-form trial metadata (patient, session, ...)",
    "calibration_toml": "str | null, aniposelib TOML of the rig",
    "cameras": "list[str] | null, cameras expected (gaps reported for these)",
}

#: Reply of the recorder's queryables.
RECORDER_REPLY = {
    "ok": "bool",
    "trial_id": "str",
    "path": "str",
    "error": "str | null",
    "summary": "dict (stop only): frames / gaps / drops per camera, keypoints, duration_s, cpu_s",
}

#: Recorder events.
RECORDER_EVENT = {
    "event": "started | stopped | error",
    "trial_id": "str",
    "path": "str",
    "summary": "dict (stopped / error)",
    "error": "str | null",
    "time_ns": "int",
}

#: What the simulated cameras show (real cameras ignore it). Sent by the API when a board recording
#: starts and stops; every camera of a node switches at the same frame id (the first one at or after
#: ``start_ns``), so the board poses stay synchronised across cameras.
CAMERA_SCENE = {
    "scene": "walker | board",
    "start_ns": "int, wall clock (ns) from which frames show the scene",
}


def check_name(name: str, *, what: str) -> str:
    """A camera or node name must be one key chunk: letters, digits, ``_ . -``."""
    if not isinstance(name, str) or not _NAME.match(name):
        raise ValueError(f"{what}: {name!r} is not a valid name (letters, digits, '_', '.', '-')")
    return name


@dataclass(frozen=True)
class Keys:
    """The key expressions of one rig prefix."""

    prefix: str = DEFAULT_PREFIX

    def __post_init__(self) -> None:
        if not self.prefix or self.prefix.startswith("/") or self.prefix.endswith("/") or "*" in self.prefix:
            raise ValueError(f"prefix: {self.prefix!r} must be like 'gaitcap/default' (no wildcards)")

    def image(self, camera: str = "*") -> str:
        return f"{self.prefix}/camera/{camera if camera == '*' else check_name(camera, what='camera')}/image"

    def status(self, camera: str = "*") -> str:
        return f"{self.prefix}/camera/{camera if camera == '*' else check_name(camera, what='camera')}/status"

    def keypoints(self, camera: str = "*") -> str:
        return f"{self.prefix}/keypoints/{camera if camera == '*' else check_name(camera, what='camera')}"

    @property
    def recorder_start(self) -> str:
        return f"{self.prefix}/recorder/start"

    @property
    def recorder_stop(self) -> str:
        return f"{self.prefix}/recorder/stop"

    @property
    def recorder_status(self) -> str:
        return f"{self.prefix}/recorder/status"

    @property
    def recorder_events(self) -> str:
        return f"{self.prefix}/recorder/events"

    @property
    def camera_scene(self) -> str:
        return f"{self.prefix}/camera/scene"

    def worker_progress(self, trial_id: str = "*") -> str:
        return f"{self.prefix}/worker/progress/{trial_id}"

    def alive(self, node: str = "**") -> str:
        return f"{self.prefix}/alive/{node if node == '**' else check_name(node, what='node')}"

    def camera_of(self, key: str) -> str:
        """The camera name in an image / status / keypoints key."""
        rest = str(key)[len(self.prefix) + 1 :].split("/")
        if str(key).startswith(self.prefix + "/") and len(rest) >= 2 and rest[0] in ("camera", "keypoints"):
            return rest[1]
        raise ValueError(f"key {key!r} names no camera under {self.prefix}")

    def node_of(self, key: str) -> str:
        return str(key).rsplit("/", 1)[-1]


def dumps(payload: dict[str, Any]) -> bytes:
    return json.dumps(payload, separators=(",", ":")).encode()


def loads(data: bytes | bytearray | memoryview, *, what: str) -> dict[str, Any]:
    """Parse a JSON payload; ValueError naming ``what`` when it is not a JSON object."""
    try:
        obj = json.loads(bytes(data))
    except (ValueError, UnicodeDecodeError) as exc:
        raise ValueError(f"{what}: payload is not JSON ({exc})") from None
    if not isinstance(obj, dict):
        raise ValueError(f"{what}: payload must be a JSON object, got {type(obj).__name__}")
    return obj
