"""Typed bus messages: one frozen dataclass per payload, ``to_bytes`` / ``from_bytes`` with bounds.

Every producer builds these and every consumer parses with ``from_bytes``, which raises ValueError
naming the message and the field when a payload is malformed, out of bounds or too large (the caller
logs it and drops the message). Frames carry ONE timestamp: the camera timestamp in the protobuf
``foxglove.CompressedImage``; the attachment (:class:`FrameMeta`) only carries the frame id and the
send time. Key expressions are in :mod:`gaitcap.services.bus.keys`.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import asdict, dataclass, field, fields
from typing import Any, ClassVar

from gaitcap.acquisition.encoding import decode_jpeg, image_message, parse_image_message
from gaitcap.acquisition.keypoint_message import check_people
from gaitcap.reconstruction.calibration_io import rig_from_toml_text
from gaitcap.services.bus.keys import check_name as _key_chunk

#: Frame ids count frames from a camera's synchronised start: 2**31 frames is 2 years at 30 frames/s.
MAX_FRAME_ID = 2**31 - 1
#: Camera / wall-clock timestamps in ns: 0 .. year 2262.
MAX_TIME_NS = 2**63 - 1
MAX_JSON_BYTES = 4 * 2**20  # a calibration TOML and trial metadata fit easily
MAX_CALIBRATION_BYTES = 2**20  # a calibration TOML of 64 cameras is about 40 kB
MAX_JPEG_BYTES = 64 * 2**20
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.\-]{0,63}$")


def _reject_constant(value: str) -> None:
    raise ValueError(f"{value} is not allowed")


def _load(data: bytes | bytearray | memoryview, what: str) -> dict[str, Any]:
    raw = bytes(data)
    if len(raw) > MAX_JSON_BYTES:
        raise ValueError(f"{what}: payload of {len(raw)} bytes exceeds {MAX_JSON_BYTES}")
    try:
        obj = json.loads(raw, parse_constant=_reject_constant)
    except (ValueError, UnicodeDecodeError) as exc:
        raise ValueError(f"{what}: payload is not JSON ({str(exc)[:120]})") from None
    if not isinstance(obj, dict):
        raise ValueError(f"{what}: payload must be a JSON object, got {type(obj).__name__}")
    return obj


def check_name(value: Any, *, what: str) -> str:
    """A camera, node or trial name: 1-64 letters, digits, ``_ . -``, no ``..``."""
    if not isinstance(value, str) or not _NAME.match(value) or ".." in value:
        raise ValueError(f"{what}: {str(value)[:80]!r} is not a valid name (1-64 letters, digits, '_', '.', '-')")
    return value


def _int(value: Any, what: str, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise ValueError(f"{what}: {str(value)[:40]} is not an integer in [{lo}, {hi}]")
    return value


def _num(value: Any, what: str, lo: float, hi: float) -> float:
    # the bounds first: math.isfinite of an integer no float holds (JSON's are unbounded) raises OverflowError
    if isinstance(value, bool) or not isinstance(value, int | float) or not lo <= value <= hi \
            or not math.isfinite(value):
        raise ValueError(f"{what}: {str(value)[:40]} is not a finite number in [{lo}, {hi}]")
    return float(value)


def _str(value: Any, what: str, max_len: int, *, optional: bool = False) -> str | None:
    if value is None and optional:
        return None
    if not isinstance(value, str) or len(value) > max_len:
        raise ValueError(f"{what}: must be a string of at most {max_len} characters")
    return value


def _choice(value: Any, what: str, choices: tuple[str, ...]) -> str:
    if value not in choices:
        raise ValueError(f"{what}: {str(value)[:40]!r} is not one of {list(choices)}")
    return value


def _dict(value: Any, what: str, *, optional: bool = True) -> dict[str, Any]:
    if value is None and optional:
        return {}
    if not isinstance(value, dict):
        raise ValueError(f"{what}: must be a JSON object")
    return value


def _calibration(value: Any, what: str) -> str | None:
    """None, or a calibration TOML (aniposelib format) of at most :data:`MAX_CALIBRATION_BYTES` that loads."""
    if value is None:
        return None
    if not isinstance(value, str) or not value.strip() or len(value.encode()) > MAX_CALIBRATION_BYTES:
        raise ValueError(f"{what}: must be a calibration TOML of 1 to {MAX_CALIBRATION_BYTES} bytes (or absent)")
    try:
        rig_from_toml_text(value, source=what)
    except (ValueError, KeyError, TypeError) as exc:
        words = str(exc)[:300]
        raise ValueError(words if words.startswith(what) else f"{what}: {words}") from None
    return value


class _Json:
    """``to_bytes`` / ``from_bytes`` for a dataclass whose ``check`` validates every field."""

    what: ClassVar[str] = "message"

    def to_bytes(self) -> bytes:
        return json.dumps(asdict(self), separators=(",", ":"), allow_nan=False).encode()

    @classmethod
    def from_bytes(cls, data: bytes | bytearray | memoryview):
        obj = _load(data, cls.what)
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(obj) - names)
        if unknown:
            raise ValueError(f"{cls.what}: unknown fields {unknown[:5]}")
        try:
            return cls(**obj)
        except TypeError as exc:
            raise ValueError(f"{cls.what}: {exc}") from None


@dataclass(frozen=True)
class FrameMeta(_Json):
    """Zenoh attachment of every image put (the camera timestamp is in the protobuf only).

    frame_id: frame counter from the synchronised start (gaps = dropped frames); sent_ns: wall clock
    (ns) when published (bus latency); ptp_jump: the interval to the previous frame differs from the
    period by > 10x; replay: published from a recording."""

    what: ClassVar[str] = "frame attachment"
    frame_id: int
    sent_ns: int
    ptp_jump: bool = False
    replay: bool = False

    def __post_init__(self) -> None:
        _int(self.frame_id, f"{self.what}.frame_id", 0, MAX_FRAME_ID)
        _int(self.sent_ns, f"{self.what}.sent_ns", 0, MAX_TIME_NS)
        if not isinstance(self.ptp_jump, bool) or not isinstance(self.replay, bool):
            raise ValueError(f"{self.what}: ptp_jump and replay must be booleans")


@dataclass(frozen=True)
class ImageFrame:
    """One camera frame as it travels: the protobuf ``foxglove.CompressedImage`` bytes and its meta."""

    camera: str
    timestamp_ns: int
    jpeg: bytes
    meta: FrameMeta
    payload: bytes

    @classmethod
    def build(cls, jpeg: bytes, *, camera: str, timestamp_ns: int, frame_id: int, sent_ns: int,
              ptp_jump: bool = False, replay: bool = False) -> ImageFrame:
        meta = FrameMeta(frame_id, sent_ns, ptp_jump, replay)
        _int(timestamp_ns, "image.timestamp_ns", 0, MAX_TIME_NS)
        return cls(camera, timestamp_ns, jpeg, meta, image_message(jpeg, camera=camera, timestamp_ns=timestamp_ns))

    @classmethod
    def from_bytes(cls, payload: bytes, attachment: bytes | None, *, camera: str) -> ImageFrame:
        """Parse a frame published on camera ``camera``'s key; the protobuf must name that camera."""
        if len(payload) > MAX_JPEG_BYTES:
            raise ValueError(f"image of camera {camera}: {len(payload)} bytes exceeds {MAX_JPEG_BYTES}")
        if attachment is None:
            raise ValueError(f"image of camera {camera}: no frame attachment")
        meta = FrameMeta.from_bytes(attachment)
        msg = parse_image_message(payload)
        if msg.camera != camera:
            raise ValueError(f"image on camera {camera}'s key names camera {msg.camera[:64]!r}")
        _int(msg.timestamp_ns, f"image of camera {camera}.timestamp_ns", 0, MAX_TIME_NS)
        return cls(camera, msg.timestamp_ns, msg.jpeg, meta, bytes(payload))

    @property
    def frame_id(self) -> int:
        return self.meta.frame_id

    def image(self):
        """The decoded (H, W, 3) uint8 BGR image; ValueError naming the camera and frame."""
        return decode_jpeg(self.jpeg, what=f"camera {self.camera} frame {self.frame_id}")


@dataclass(frozen=True)
class Keypoints(_Json):
    """2D keypoints of one frame of one camera (people[0] is the patient): ``people`` is P lists of J
    ``[x px, y px, confidence 0..1]``; ``timestamp_ns`` is the frame's camera timestamp. The format and its
    checks are :mod:`gaitcap.acquisition.keypoint_message`'s (a recording's reader reads the same
    messages); the bus adds its bounds: names, frame id and timestamp ranges, no NaN (a joint not seen is
    ``[0, 0, 0]``), no unknown field."""

    what: ClassVar[str] = "keypoints"
    camera: str
    frame_id: int
    timestamp_ns: int
    skeleton: str
    people: list
    detector_ms: float = 0.0

    def __post_init__(self) -> None:
        check_name(self.camera, what=f"{self.what}.camera")
        _int(self.frame_id, f"{self.what}.frame_id", 0, MAX_FRAME_ID)
        _int(self.timestamp_ns, f"{self.what}.timestamp_ns", 0, MAX_TIME_NS)
        check_name(self.skeleton, what=f"{self.what}.skeleton")
        _num(self.detector_ms, f"{self.what}.detector_ms", 0.0, 3.6e6)
        check_people(self.people, camera=self.camera, allow_nan=False)  # the fields above are checked here


@dataclass(frozen=True)
class CameraStatus(_Json):
    """Status of one camera (about once per second and on every state change)."""

    what: ClassVar[str] = "camera status"
    camera: str
    node: str
    state: str
    health: str
    fps: float = 0.0
    frames: int = 0
    drops: int = 0
    last_timestamp_ns: int | None = None
    last_frame_id: int | None = None
    ptp_jumps: int = 0
    error: str | None = None
    time_ns: int = 0
    published: int = 0
    extra: dict = field(default_factory=dict)

    STATES: ClassVar[tuple[str, ...]] = ("closed", "open", "configured", "running", "stopped", "error")

    def __post_init__(self) -> None:
        check_name(self.camera, what=f"{self.what}.camera")
        check_name(self.node, what=f"{self.what}.node")
        _choice(self.state, f"{self.what}.state", self.STATES)
        _str(self.health, f"{self.what}.health", 64)
        _num(self.fps, f"{self.what}.fps", 0.0, 1e5)
        for name in ("frames", "drops", "ptp_jumps", "published"):
            _int(getattr(self, name), f"{self.what}.{name}", 0, 2**63 - 1)
        if self.last_timestamp_ns is not None:
            _int(self.last_timestamp_ns, f"{self.what}.last_timestamp_ns", 0, MAX_TIME_NS)
        if self.last_frame_id is not None:
            _int(self.last_frame_id, f"{self.what}.last_frame_id", 0, MAX_FRAME_ID)
        _str(self.error, f"{self.what}.error", 2000, optional=True)
        _int(self.time_ns, f"{self.what}.time_ns", 0, MAX_TIME_NS)
        _dict(self.extra, f"{self.what}.extra", optional=False)

    @classmethod
    def of_driver(cls, status: dict[str, Any], *, node: str, time_ns: int, published: int) -> CameraStatus:
        """From ``DriverStatus.to_dict()`` (driver-specific keys go to ``extra``)."""
        known = {f.name for f in fields(cls)}
        base = {k: v for k, v in status.items() if k in known}
        extra = {k: v for k, v in status.items() if k not in known}
        return cls(**base, node=node, time_ns=time_ns, published=published, extra=extra)

    def to_dict(self) -> dict[str, Any]:
        out = asdict(self)
        out.update(out.pop("extra"))
        return out


@dataclass(frozen=True)
class RecorderStart(_Json):
    """Start recording ``trial_id`` into ``path`` (relative to the recorder's data folder, or inside it)."""

    what: ClassVar[str] = "recorder start"
    trial_id: str
    path: str
    metadata: dict = field(default_factory=dict)
    calibration_toml: str | None = None
    cameras: list | None = None

    def __post_init__(self) -> None:
        check_name(self.trial_id, what=f"{self.what}.trial_id")
        if not self.path:
            raise ValueError(f"{self.what} {self.trial_id}: missing path")
        _str(self.path, f"{self.what}.path", 4096)
        if "\x00" in self.path:
            raise ValueError(f"{self.what}.path: contains a NUL byte")
        _dict(self.metadata, f"{self.what}.metadata", optional=False)
        _calibration(self.calibration_toml, f"{self.what}.calibration_toml")
        if self.cameras is not None:
            if not isinstance(self.cameras, list) or len(self.cameras) > 256:
                raise ValueError(f"{self.what}.cameras: must be a list of at most 256 camera names")
            for c in self.cameras:
                check_name(c, what=f"{self.what}.cameras")


@dataclass(frozen=True)
class RecorderStop(_Json):
    what: ClassVar[str] = "recorder stop"
    trial_id: str

    def __post_init__(self) -> None:
        check_name(self.trial_id, what=f"{self.what}.trial_id")


@dataclass(frozen=True)
class RecorderReply(_Json):
    """Reply of the recorder's queryables (``ok`` false + ``error`` on refusal); ``summary`` on stop;
    ``recording`` / ``queued`` on status."""

    what: ClassVar[str] = "recorder reply"
    ok: bool
    trial_id: str | None = None
    path: str | None = None
    error: str | None = None
    summary: dict | None = None
    recording: bool | None = None
    queued: int | None = None


@dataclass(frozen=True)
class RecorderEvent(_Json):
    what: ClassVar[str] = "recorder event"
    event: str
    trial_id: str
    path: str
    time_ns: int
    error: str | None = None
    summary: dict | None = None

    def __post_init__(self) -> None:
        _choice(self.event, f"{self.what}.event", ("started", "stopped", "error"))
        check_name(self.trial_id, what=f"{self.what}.trial_id")
        _int(self.time_ns, f"{self.what}.time_ns", 0, MAX_TIME_NS)


@dataclass(frozen=True)
class CameraScene(_Json):
    """What simulated cameras show from ``start_ns`` (wall clock, ns); real cameras ignore it."""

    what: ClassVar[str] = "camera scene"
    scene: str
    start_ns: int

    def __post_init__(self) -> None:
        _choice(self.scene, f"{self.what}.scene", ("walker", "board"))
        _int(self.start_ns, f"{self.what}.start_ns", 0, MAX_TIME_NS)


COVERAGE_COUNTS = ("received", "detected", "skipped", "lost", "failed")


@dataclass(frozen=True)
class DetectorStatus(_Json):
    """A detector node's live coverage (about once per second): ``workers`` alive of ``pool``; per camera
    ``{received, detected, skipped, lost, failed}`` frame counts since the node started and ``lag_s``, the
    time from the camera node's send to the keypoints' publication of its latest detected frame (s)."""

    what: ClassVar[str] = "detector status"
    node: str
    time_ns: int
    workers: int
    pool: int
    cameras: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        check_name(self.node, what=f"{self.what}.node")
        _int(self.time_ns, f"{self.what}.time_ns", 0, MAX_TIME_NS)
        _int(self.pool, f"{self.what}.pool", 1, 4096)
        _int(self.workers, f"{self.what}.workers", 0, self.pool)
        _dict(self.cameras, f"{self.what}.cameras", optional=False)
        if len(self.cameras) > 256:
            raise ValueError(f"{self.what}.cameras: {len(self.cameras)} cameras, at most 256")
        for cam, row in self.cameras.items():
            where = f"{self.what}.cameras.{check_name(cam, what=f'{self.what}.cameras')}"
            _dict(row, where, optional=False)
            for key in COVERAGE_COUNTS:
                _int(row.get(key), f"{where}.{key}", 0, MAX_FRAME_ID)
            if row.get("lag_s") is not None:
                _num(row["lag_s"], f"{where}.lag_s", 0.0, 1e6)
            unknown = sorted(set(row) - {*COVERAGE_COUNTS, "lag_s"})
            if unknown:
                raise ValueError(f"{where}: unknown fields {unknown[:5]}")


MAX_BOARD_CORNERS = 10_000


@dataclass(frozen=True)
class BoardWatch(_Json):
    """Look for the board of board recording ``calibration_id`` in the frames (``active``), or stop looking
    (not ``active``). ``board``: the board's ``[board]`` fields as in a gaitcap board file (None: the default
    board); ``slot_s``: one frame per camera and slot of ``slot_s`` s of camera time is looked at (the
    same slots on every detector node, so views of one slot are of one moment)."""

    what: ClassVar[str] = "board watch"
    calibration_id: str
    active: bool
    board: dict | None = None
    slot_s: float = 0.5

    def __post_init__(self) -> None:
        check_name(self.calibration_id, what=f"{self.what}.calibration_id")
        if not isinstance(self.active, bool):
            raise ValueError(f"{self.what}.active: must be true or false")
        if self.board is not None:
            _dict(self.board, f"{self.what}.board", optional=False)
        _num(self.slot_s, f"{self.what}.slot_s", 0.05, 60.0)


@dataclass(frozen=True)
class BoardView(_Json):
    """One frame looked at for the board of board recording ``calibration_id``: the camera, its frame id
    and camera timestamp (ns), the image size (px) and the board corners found ([x, y] px rows, pixel
    centres at integers; corners not found left out; empty: no board in the frame)."""

    what: ClassVar[str] = "board view"
    calibration_id: str
    camera: str
    frame_id: int
    timestamp_ns: int
    width_px: int
    height_px: int
    corners: list = field(default_factory=list)

    def __post_init__(self) -> None:
        check_name(self.calibration_id, what=f"{self.what}.calibration_id")
        check_name(self.camera, what=f"{self.what}.camera")
        _int(self.frame_id, f"{self.what}.frame_id", 0, MAX_FRAME_ID)
        _int(self.timestamp_ns, f"{self.what}.timestamp_ns", 0, MAX_TIME_NS)
        _int(self.width_px, f"{self.what}.width_px", 1, 65535)
        _int(self.height_px, f"{self.what}.height_px", 1, 65535)
        if not isinstance(self.corners, list) or len(self.corners) > MAX_BOARD_CORNERS:
            raise ValueError(f"{self.what}.corners: must be a list of at most {MAX_BOARD_CORNERS} [x, y] rows")
        for row in self.corners:
            if not isinstance(row, list) or len(row) != 2:
                raise ValueError(f"{self.what}.corners: every row must be [x, y] px")
            for v in row:
                _num(v, f"{self.what}.corners", -65535.0, 2 * 65535.0)


MAX_CHUNK_BYTES = 8 << 20  # a recording chunk's reply carries at most this many bytes
MAX_FILE_BYTES = 1 << 46


@dataclass(frozen=True)
class ChunkRequest(_Json):
    """The payload of a query on ``<prefix>/recorder/recording/<trial_id>``: ``length`` bytes from ``offset``
    of trial ``trial_id``'s finished recording ``name`` (its file name)."""

    what: ClassVar[str] = "recording chunk request"
    trial_id: str
    name: str
    offset: int
    length: int

    def __post_init__(self) -> None:
        check_name(self.trial_id, what=f"{self.what}.trial_id")
        if not _key_chunk(self.name, what=f"{self.what}.name").endswith(".mcap"):
            raise ValueError(f"{self.what}.name: {self.name!r} is not an .mcap file name")
        _int(self.offset, f"{self.what}.offset", 0, MAX_FILE_BYTES)
        _int(self.length, f"{self.what}.length", 1, MAX_CHUNK_BYTES)


@dataclass(frozen=True)
class ChunkReply(_Json):
    """The attachment of a recording chunk's reply (the bytes are its payload): its ``offset`` and the
    recording's ``size`` (bytes); or ``error``, the recorder's refusal, with ``transient`` true when asking
    again may succeed (the recorder could not read the file just now) and false when it cannot (no such
    finished recording there, a request it does not serve)."""

    what: ClassVar[str] = "recording chunk reply"
    offset: int = 0
    size: int = 0
    error: str | None = None
    transient: bool = False

    def __post_init__(self) -> None:
        _int(self.offset, f"{self.what}.offset", 0, MAX_FILE_BYTES)
        _int(self.size, f"{self.what}.size", 0, MAX_FILE_BYTES)
        _str(self.error, f"{self.what}.error", 2000, optional=True)
        if not isinstance(self.transient, bool):
            raise ValueError(f"{self.what}.transient: must be true or false")
