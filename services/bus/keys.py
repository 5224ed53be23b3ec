"""Every Zenoh key expression of gaitcap; the payloads are the typed messages of
:mod:`gaitcap.services.bus.messages` (one frozen dataclass each, ``to_bytes`` / ``from_bytes``).

All keys live under a rig prefix (default ``gaitcap/default``; one prefix per rig so several rigs can
share a network). ``<cam>`` is a camera name as in the calibration, ``<node>`` a node name.

=======================================  ==========  ========================================================
key expression                           kind        payload (``messages.``)
=======================================  ==========  ========================================================
``<prefix>/camera/<cam>/image``          put         protobuf ``foxglove.CompressedImage`` (JPEG; its
                                                     ``timestamp`` is THE camera timestamp) with a
                                                     :class:`FrameMeta` attachment (frame id, send time):
                                                     :class:`ImageFrame`
``<prefix>/camera/<cam>/status``         put         :class:`CameraStatus` (about once per second and on
                                                     every state change)
``<prefix>/keypoints/<cam>``             put         :class:`Keypoints` (one message per frame and camera)
``<prefix>/recorder/start``              queryable   :class:`RecorderStart`; reply :class:`RecorderReply`
                                                     (``ok`` false + ``error`` on refusal)
``<prefix>/recorder/stop``               queryable   :class:`RecorderStop`; reply :class:`RecorderReply`
                                                     with the trial summary
``<prefix>/recorder/status``             queryable   no payload; reply :class:`RecorderReply` (``recording``)
``<prefix>/recorder/events``             put         :class:`RecorderEvent`
``<prefix>/recorder/recording/<trial>``  queryable   :class:`ChunkRequest` (bytes of a finished recording);
                                                     reply: the bytes, with a :class:`ChunkReply` attachment
                                                     (:mod:`~gaitcap.services.bus.recording_transfer`)
``<prefix>/alive/<node>``                liveliness  token held by every node while it runs
``<prefix>/detector/status/<node>``      put         :class:`DetectorStatus`: per camera frames received,
                                                     detected, skipped, lost, failed and the lag (s)
``<prefix>/camera/scene``                put         :class:`CameraScene`: what simulated cameras show
``<prefix>/board/watch``                 put         :class:`BoardWatch`: look for the board of a board
                                                     recording in the frames (or stop looking)
``<prefix>/board/views/<cam>``           put         :class:`BoardView`: the board's corners found in one
                                                     frame looked at (none: not found)
=======================================  ==========  ========================================================

Wildcards: ``<prefix>/camera/*/image`` (all frames), ``<prefix>/keypoints/*``, ``<prefix>/alive/**``.
Who may put or query which key is enforced by Zenoh access control (:mod:`gaitcap.services.bus.security`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

DEFAULT_PREFIX = "gaitcap/default"
_NAME = re.compile(r"^[A-Za-z0-9_.\-]+$")


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

    def recording(self, trial_id: str = "*") -> str:
        """A trial's finished recording, served by the recorder (``*``: every trial's, its queryable)."""
        trial = trial_id if trial_id == "*" else check_name(trial_id, what="trial")
        return f"{self.prefix}/recorder/recording/{trial}"

    @property
    def camera_scene(self) -> str:
        return f"{self.prefix}/camera/scene"

    @property
    def board_watch(self) -> str:
        return f"{self.prefix}/board/watch"

    def board_views(self, camera: str = "*") -> str:
        return f"{self.prefix}/board/views/{camera if camera == '*' else check_name(camera, what='camera')}"

    def detector_status(self, node: str = "*") -> str:
        return f"{self.prefix}/detector/status/{node if node == '*' else check_name(node, what='node')}"

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
