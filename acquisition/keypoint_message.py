"""The keypoint message: one camera frame's 2D keypoints as JSON; its format and checks, in one place.

A message is a JSON object with ``frame_id`` (integer), ``timestamp_ns`` (integer: the frame's camera
timestamp, ns), ``skeleton`` (its name) and ``people``: P <= :data:`MAX_PEOPLE` lists of the same
J (1..:data:`MAX_JOINTS`) ``[x px, y px, confidence 0..1]`` (people[0] is the patient); optional
``camera`` (its name) and ``detector_ms`` (>= 0). Coordinates are finite, within
+-:data:`MAX_IMAGE_PX`. A joint not seen has confidence 0: the detectors mark it NaN, and the detector
node sends it as ``[0, 0, 0]`` (JSON on the bus has no NaN); where NaN can be read (a recording written
by a tool whose JSON allows it), x and y may be NaN for a joint of confidence 0, never otherwise.
Infinite values and confidences outside 0..1 are refused.

The ranges of frame ids and timestamps are the readers' (the bus bounds them, a recording's reader
counts a message far outside the recording as stray), not the format's.
"""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from typing import Any

import numpy as np

MAX_PEOPLE = 32
MAX_JOINTS = 256
MAX_IMAGE_PX = 100_000  # a keypoint coordinate beyond this (px) is not from a camera image
REQUIRED = ("frame_id", "timestamp_ns", "skeleton", "people")


class KeypointMessageError(ValueError):
    """A keypoint message that does not hold to the format: the message names the camera and the field
    (``people[0][3].x``); :attr:`reason` says what is wrong in a few words without indices or values, the
    same for every message with that fault (a recording's reader counts ignored messages by it)."""

    def __init__(self, camera: str | None, field: str, why: str, value: Any = None) -> None:
        self.field, self.why = field, why
        where = f"keypoints of camera {camera}" if camera else "keypoints"
        got = "" if value is None else f" (got {str(value)[:40]})"
        super().__init__(f"{where}.{field}: {why}{got}" if field else f"{where}: {why}")

    @property
    def reason(self) -> str:
        """``'people' confidence not a number in 0..1``: the field without indices, what is wrong."""
        root = self.field.split("[")[0].split(".")[0]
        leaf = self.field.rpartition(".")[2] if "." in self.field else ""
        return " ".join(w for w in (f"'{root}'" if root else "", leaf, self.why) if w)


@dataclass(frozen=True, eq=False)
class KeypointMessage:
    """One read keypoint message: ``people`` (P, J, 3) x px, y px, confidence (P = 0: nobody seen)."""

    frame_id: int
    timestamp_ns: int
    skeleton: str
    people: np.ndarray
    camera: str | None = None
    detector_ms: float | None = None


def parse_keypoint_message(data: bytes | bytearray | memoryview, *, camera: str | None = None,
                           allow_nan: bool = True) -> KeypointMessage:
    """Bytes of one keypoint message -> :class:`KeypointMessage`; :class:`KeypointMessageError` naming
    ``camera`` (the one it was recorded or sent for) and the field when it cannot be read."""
    try:
        obj = json.loads(bytes(data))
    except ValueError:  # bad JSON or bad UTF-8
        raise KeypointMessageError(camera, "", "not JSON") from None
    return keypoint_message_of(obj, camera=camera, allow_nan=allow_nan)


def keypoint_message_of(obj: Any, *, camera: str | None = None, allow_nan: bool = True) -> KeypointMessage:
    """A decoded keypoint message (a JSON object) checked against the format; ``allow_nan``: x and y of
    a joint of confidence 0 may be NaN."""
    if not isinstance(obj, dict):
        raise KeypointMessageError(camera, "", "not a JSON object")
    missing = [k for k in REQUIRED if k not in obj]
    if missing:
        raise KeypointMessageError(camera, "", "missing " + ", ".join(f"'{k}'" for k in missing))
    for key in ("frame_id", "timestamp_ns"):
        if isinstance(obj[key], bool) or not isinstance(obj[key], int):
            raise KeypointMessageError(camera, key, "not an integer", obj[key])
    if not isinstance(obj["skeleton"], str) or not obj["skeleton"]:
        raise KeypointMessageError(camera, "skeleton", "not a name", obj["skeleton"])
    if obj.get("camera") is not None and not isinstance(obj["camera"], str):
        raise KeypointMessageError(camera, "camera", "not a name", obj["camera"])
    ms = obj.get("detector_ms")
    if ms is not None and (isinstance(ms, bool) or not isinstance(ms, int | float) or not 0 <= ms <= sys.float_info.max):
        raise KeypointMessageError(camera, "detector_ms", "not a finite number >= 0", ms)
    people = check_people(obj["people"], camera=camera, allow_nan=allow_nan)
    return KeypointMessage(obj["frame_id"], obj["timestamp_ns"], obj["skeleton"], people, obj.get("camera"),
                           None if ms is None else float(ms))


def check_people(value: Any, *, camera: str | None = None, allow_nan: bool = True) -> np.ndarray:
    """``people`` of a keypoint message -> (P, J, 3) float64; :class:`KeypointMessageError` naming the
    person, joint and coordinate at fault."""
    if isinstance(value, list) and not value:
        return np.zeros((0, 0, 3))
    arr = _array(value)
    if arr is None:
        _check_structure(value, camera)
        arr = np.asarray(value, dtype=np.float64)
    _check_values(arr, camera, allow_nan)
    return arr


def _array(value: Any) -> np.ndarray | None:
    """The fast path: ``value`` as one (P, J, 3) array when its shape and counts hold, else None."""
    if not isinstance(value, list) or len(value) > MAX_PEOPLE:
        return None
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError):  # ragged
        return None
    if arr.dtype.kind not in "iuf" or arr.ndim != 3 or arr.shape[2] != 3 or not 0 < arr.shape[1] <= MAX_JOINTS:
        return None
    return arr.astype(np.float64, copy=False)


def _check_structure(value: Any, camera: str | None) -> None:
    """Raise naming the first person or joint that is not a list of the right length of numbers."""
    if not isinstance(value, list) or len(value) > MAX_PEOPLE:
        raise KeypointMessageError(camera, "people", f"must be a list of at most {MAX_PEOPLE} people")
    joints = None
    for p, person in enumerate(value):
        if not isinstance(person, list) or not 0 < len(person) <= MAX_JOINTS:
            raise KeypointMessageError(camera, f"people[{p}]", f"must be a list of 1..{MAX_JOINTS} joints")
        if joints is not None and len(person) != joints:
            raise KeypointMessageError(camera, f"people[{p}]", f"{len(person)} joints, person 0 has {joints}")
        joints = len(person)
        for j, xyc in enumerate(person):
            if not isinstance(xyc, list) or len(xyc) != 3:
                raise KeypointMessageError(camera, f"people[{p}][{j}]", "must be [x px, y px, confidence]")
            for name, v in zip(("x", "y", "confidence"), xyc, strict=True):
                if isinstance(v, bool) or not isinstance(v, int | float):
                    raise KeypointMessageError(camera, f"people[{p}][{j}].{name}", "not a number", v)
                if isinstance(v, int) and abs(v) >= 2**1023:  # JSON integers are unbounded: no float holds it
                    why = "not a number in 0..1" if name == "confidence" else f"beyond +-{MAX_IMAGE_PX} px"
                    raise KeypointMessageError(camera, f"people[{p}][{j}].{name}", why, v)


def _check_values(arr: np.ndarray, camera: str | None, allow_nan: bool) -> None:
    """Confidences finite in 0..1; x, y finite within +-MAX_IMAGE_PX, or NaN (``allow_nan``) where the
    confidence is 0 (a joint not seen). Comparisons with NaN are False: NaN fails both bounds."""
    conf, xy = arr[..., 2], arr[..., :2]
    bad_conf = ~((conf >= 0) & (conf <= 1))
    if bad_conf.any():
        p, j = np.argwhere(bad_conf)[0]
        raise KeypointMessageError(camera, f"people[{p}][{j}].confidence", "not a number in 0..1", conf[p, j])
    bad_xy = ~(np.abs(xy) <= MAX_IMAGE_PX)
    if allow_nan and bad_xy.any():
        bad_xy &= ~(np.isnan(xy) & (conf == 0)[..., None])
    if bad_xy.any():
        p, j, k = np.argwhere(bad_xy)[0]
        v = xy[p, j, k]
        why = ("NaN with a confidence above 0 (a joint not seen has confidence 0)" if np.isnan(v) and allow_nan
               else "not a finite number" if not np.isfinite(v) else f"beyond +-{MAX_IMAGE_PX} px")
        raise KeypointMessageError(camera, f"people[{p}][{j}].{'xy'[k]}", why, v)
