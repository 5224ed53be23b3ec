"""Read trial MCAPs: detections, calibration, metadata, frames; scan files cut short by a crash.

Complete files are read through the MCAP index (keypoints without touching image chunks). A file without
a valid summary (``<path>.part`` left by a recorder that died, or a truncated copy) is scanned record by
record: every complete chunk is used, a chunk that fails its CRC or decompression is skipped and counted,
and the scan stops at the first cut or unreadable record. Nothing here can loop forever: every read
consumes bytes of a finite file and record lengths are capped at the file size.
"""

from __future__ import annotations

import json
import logging
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from gaitcap.acquisition.encoding import parse_image_message
from gaitcap.acquisition.keypoint_message import KeypointMessageError, parse_keypoint_message
from gaitcap.acquisition.recording import layout
from gaitcap.acquisition.recording.frame_slots import SlotReport, align_frame_slots
from gaitcap.reconstruction.calibration_io import rig_from_toml_text
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.ignored_keypoints import IgnoredKeypoints
from gaitcap.reconstruction.keypoints import MultiViewKeypoints, missing_keypoints
from gaitcap.reconstruction.skeletons import get_skeleton
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.reader import SeekingReader
from mcap.records import Attachment, Channel, Chunk, Footer, Message, Metadata, Schema
from mcap.stream_reader import StreamReader, breakup_chunk

log = logging.getLogger(__name__)

TopicFilter = Callable[[str], bool]


def resolve_recording(path: str | os.PathLike) -> Path:
    """``path`` if it exists, else ``path.part`` (a recording in progress or cut short)."""
    p = Path(path)
    if p.is_file():
        return p
    part = p.with_name(p.name + layout.PART_SUFFIX)
    if part.is_file():
        return part
    raise FileNotFoundError(f"recording {p} not found (nor {part.name})")


def _seeking(f, size: int) -> SeekingReader:
    return SeekingReader(f, record_size_limit=max(size, 1))


def is_complete(path: str | os.PathLike) -> bool:
    """True when the file ends with a valid MCAP footer and summary (safe for indexed reads)."""
    p = resolve_recording(path)
    size = p.stat().st_size
    try:
        with open(p, "rb") as f:
            return _seeking(f, size).get_summary() is not None
    except (McapError, ValueError, EOFError, OSError, KeyError, IndexError):
        return False


@dataclass
class ScanState:
    """What a record-by-record scan found besides messages."""

    path: Path
    complete: bool = False
    chunks: int = 0
    corrupt_chunks: int = 0
    error: str | None = None
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    attachments: dict[str, bytes] = field(default_factory=dict)
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)


def _check_magic(path: Path) -> None:
    with open(path, "rb") as f:
        head = f.read(8)
    if head != b"\x89MCAP0\r\n":
        raise ValueError(f"{path}: not an MCAP file (bad magic {head[:8]!r})")


def _chunk_records(chunk: Chunk, state: ScanState) -> list:
    try:
        records = breakup_chunk(chunk, validate_crc=True)
    except Exception as exc:  # CRC mismatch, lz4/zstd errors, cut records inside the chunk
        state.corrupt_chunks += 1
        log.warning("%s: skipping a corrupt chunk (%s)", state.path, exc)
        return []
    state.chunks += 1
    return records


def scan(path: Path, state: ScanState, wanted: TopicFilter | None = None) -> Iterator[tuple[str, Message]]:
    """Yield (topic, message) of every complete record in file order; fills ``state``."""
    _check_magic(path)
    size = path.stat().st_size
    with open(path, "rb") as f:
        reader = StreamReader(f, validate_crcs=False, emit_chunks=True, record_size_limit=max(size, 1))
        records = reader.records
        while True:
            try:
                record = next(records)
            except StopIteration:
                return
            except Exception as exc:  # EndOfFile, RecordLengthLimitExceeded, garbage
                state.error = f"{type(exc).__name__} after {state.chunks} complete chunks: {exc}".strip()
                return
            inner = _chunk_records(record, state) if isinstance(record, Chunk) else [record]
            for rec in inner:
                if isinstance(rec, Schema):
                    state.schemas[rec.id] = rec
                elif isinstance(rec, Channel):
                    state.channels[rec.id] = rec
                elif isinstance(rec, Metadata):
                    state.metadata[rec.name] = dict(rec.metadata)
                elif isinstance(rec, Attachment):
                    state.attachments[rec.name] = bytes(rec.data)
                elif isinstance(rec, Footer):
                    state.complete = True
                elif isinstance(rec, Message):
                    channel = state.channels.get(rec.channel_id)
                    if channel is None:
                        continue
                    if wanted is None or wanted(channel.topic):
                        yield channel.topic, rec


def iter_messages(path: str | os.PathLike, wanted: TopicFilter) -> Iterator[tuple[str, Message]]:
    """(topic, message) for topics accepted by ``wanted``: indexed when complete, else scanned."""
    p = resolve_recording(path)
    if is_complete(p):
        size = p.stat().st_size
        with open(p, "rb") as f:
            reader = _seeking(f, size)
            summary = reader.get_summary()
            topics = sorted({c.topic for c in summary.channels.values() if wanted(c.topic)})
            if not topics:
                return
            messages = reader.iter_messages(topics=topics, log_time_order=True)
            while True:
                try:
                    _, channel, message = next(messages)
                except StopIteration:
                    return
                except Exception as exc:  # lz4/zstd errors, bad records inside a chunk
                    raise ValueError(f"{p}: corrupt data ({type(exc).__name__}: {exc}); "
                                     "gaitcap.acquisition.recording.recovery.recover() keeps every intact chunk") from None
                yield channel.topic, message
    state = ScanState(p)
    yield from scan(p, state, wanted)
    if state.error:
        log.warning("%s is incomplete: read up to the cut (%s)", p, state.error)


def _first_json(path: str | os.PathLike, topic: str) -> dict[str, Any] | None:
    for _, message in iter_messages(path, lambda t: t == topic):
        return json.loads(message.data)
    return None


def read_metadata(path: str | os.PathLike) -> dict[str, Any]:
    """The trial metadata given at the start of the recording."""
    meta = _first_json(path, layout.TRIAL_METADATA_TOPIC)
    if meta is None:
        raise ValueError(f"{path}: no trial metadata recorded ({layout.TRIAL_METADATA_TOPIC})")
    return meta


def read_calibration(path: str | os.PathLike) -> Rig:
    """The calibration recorded with the trial, as a :class:`~gaitcap.reconstruction.camera.Rig`."""
    calib = _first_json(path, layout.CALIBRATION_TOPIC)
    if calib is None:
        raise ValueError(f"{path}: no calibration recorded ({layout.CALIBRATION_TOPIC})")
    return rig_from_toml_text(calib["toml"], source=f"{path} {layout.CALIBRATION_TOPIC}")


def read_summary(path: str | os.PathLike) -> dict[str, Any]:
    """The recorder's summary (frames, gaps per camera, error); {} when the recording was cut short."""
    p = resolve_recording(path)
    if not is_complete(p):
        return {}
    with open(p, "rb") as f:
        for record in _seeking(f, p.stat().st_size).iter_metadata():
            if record.name == layout.SUMMARY_RECORD:
                return {k: json.loads(v) for k, v in record.metadata.items()}
    return {}


def read_status(path: str | os.PathLike) -> dict[str, list[dict[str, Any]]]:
    """{camera: [status messages in time order]}."""
    out: dict[str, list[dict[str, Any]]] = {}
    for topic, message in iter_messages(path, layout.is_status_topic):
        out.setdefault(layout.camera_of_topic(topic), []).append(json.loads(message.data))
    return out


def read_image_times(path: str | os.PathLike, cameras=None) -> dict[str, np.ndarray]:
    """{camera: camera timestamps ns (N,) of its images, sorted}: what a recording without the recorder's
    summary (recovered after a crash) holds. A complete file is read through its message index (the image
    chunks are neither read nor decompressed); a file without one is scanned (message headers, no JPEG
    decoded). ``cameras``: only these (None: all)."""

    def wanted(topic: str) -> bool:
        return layout.is_image_topic(topic) and (cameras is None or layout.camera_of_topic(topic) in cameras)

    p = resolve_recording(path)
    indexed = _indexed_log_times(p, wanted) if is_complete(p) else None
    if indexed is not None:
        return {c: np.sort(np.concatenate(t)) for c, t in indexed.items()}
    out: dict[str, list[int]] = {}
    for topic, message in iter_messages(p, wanted):
        out.setdefault(layout.camera_of_topic(topic), []).append(message.log_time)
    return {c: np.sort(np.asarray(t, dtype=np.int64)) for c, t in out.items()}


_INDEX_HEAD = 1 + 8 + 2 + 4  # opcode, record length, channel id, entries length


def _indexed_log_times(p: Path, wanted: TopicFilter) -> dict[str, list[np.ndarray]] | None:
    """Log times per camera from the chunks' message index records; None when the index does not hold
    every message of the wanted channels (written without one)."""
    with open(p, "rb") as f:
        summary = _seeking(f, p.stat().st_size).get_summary()
        channels = {cid: layout.camera_of_topic(c.topic) for cid, c in summary.channels.items() if wanted(c.topic)}
        out: dict[str, list[np.ndarray]] = {cam: [] for cam in channels.values()}
        for chunk in summary.chunk_indexes:
            for cid, offset in chunk.message_index_offsets.items():
                if cid in channels:
                    f.seek(offset)
                    head = f.read(_INDEX_HEAD)
                    if (len(head) < _INDEX_HEAD or head[0] != Opcode.MESSAGE_INDEX
                            or int.from_bytes(head[9:11], "little") != cid):
                        return None  # the summary points at something else: scan the file instead
                    length = int.from_bytes(head[11:15], "little")
                    entries = np.frombuffer(f.read(length), dtype="<u8").reshape(-1, 2)
                    out[channels[cid]].append(entries[:, 0].astype(np.int64))
    counts = summary.statistics.channel_message_counts if summary.statistics else {}
    if any(sum(t.size for t in out[cam]) != counts.get(cid, -1) for cid, cam in channels.items()):
        return None
    return {cam: t for cam, t in out.items() if t}


@dataclass(frozen=True)
class RecordedFrame:
    """One recorded frame (JPEG still compressed)."""

    camera: str
    frame_id: int
    timestamp_ns: int
    jpeg: bytes

    def image(self) -> np.ndarray:
        from gaitcap.acquisition.encoding import decode_jpeg

        return decode_jpeg(self.jpeg, what=f"camera {self.camera} frame {self.frame_id}")


def iter_frames(path: str | os.PathLike, camera: str | None = None) -> Iterator[RecordedFrame]:
    """Frames in log-time order (all cameras, or one)."""

    def wanted(topic: str) -> bool:
        return layout.is_image_topic(topic) and (camera is None or layout.camera_of_topic(topic) == camera)

    for topic, message in iter_messages(path, wanted):
        img = parse_image_message(message.data)
        yield RecordedFrame(layout.camera_of_topic(topic), int(message.sequence), img.timestamp_ns, img.jpeg)


class NoKeypointsRecorded(ValueError):
    """A recording without one usable keypoint message (its images, if any, are still there)."""


_MAX_FRAME_ID = 2**53  # a frame id this large (either sign) is stray without placing it (exact in float64)


def frame_times_s(timestamps_ns: np.ndarray) -> np.ndarray:
    """(T,) s since the first frame set: the median camera timestamp of each frame set ((C, T) ns, -1 where
    missing), interpolated where no camera has one.

    Always strictly increasing: where a frame set's median does not increase (a camera's frame stamped
    more than half a period off its slot, e.g. a software-timed camera that ran late, with the other cameras
    missing from that set), the frame sets are held to within 0.45 frame period of their frame grid (see
    :func:`_onto_frame_grid`), with a warning (:func:`frame_sets_held` counts them for the trial's quality);
    a recording whose times already increase is left as it is."""
    return _frame_times(timestamps_ns)[0]


def frame_sets_held(timestamps_ns: np.ndarray) -> int:
    """How many frame sets of (C, T) camera timestamps (ns, -1 where missing) :func:`frame_times_s` moves
    onto their frame grid (0: their times increase as stamped)."""
    return _frame_times(timestamps_ns)[1]


def _frame_times(timestamps_ns: np.ndarray) -> tuple[np.ndarray, int]:
    """(frame times s (T,), frame sets held to their grid)."""
    # Relative to the earliest stamp before going to float: float64 holds absolute ns only to 256 ns.
    ref = int(timestamps_ns[timestamps_ns >= 0].min()) if (timestamps_ns >= 0).any() else 0
    ts = np.where(timestamps_ns >= 0, timestamps_ns - ref, np.nan).astype(np.float64)
    with np.errstate(all="ignore"):
        med = np.nanmedian(np.where(np.isnan(ts).all(0, keepdims=True), 0, ts), axis=0)
    have = ~np.isnan(ts).all(axis=0)
    if have.sum() == 0:
        raise ValueError("keypoints: no timestamps")
    idx = np.arange(ts.shape[1])
    if have.sum() == 1:
        filled = med[have][0] + (idx - idx[have][0]) * 1e9 / 30
        return (filled - filled[0]) / 1e9, 0
    known, moved = med[have], 0
    if np.any(np.diff(known) <= 0):
        known, moved = _onto_frame_grid(ts, idx[have], known)
    filled = np.interp(idx, idx[have], known)
    return (filled - filled[0]) / 1e9, moved


_GRID_WINDOW = 15  # frame sets: the local frame grid follows a slow drift of the camera clocks
_GRID_HOLD = 0.45  # frame periods a frame set's time may lie off its grid (under half: always increasing)


def _onto_frame_grid(ts: np.ndarray, slots: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, int]:
    """Frame sets' times (ns, relative) held to within 0.45 period of the local frame grid, and how many moved.

    ts: (C, T) camera stamps (ns, relative, NaN where missing). slots: (K,) frame-set indices with a time.
    times: (K,) their median stamps (ns). The period is the median over cameras of a frame's step in
    time per frame slot; the grid's offset is a running median (15 frame sets) of ``time - period * slot``
    so that it follows a slow drift."""
    from scipy.ndimage import median_filter

    steps = [np.diff(row[~np.isnan(row)]) / np.diff(np.flatnonzero(~np.isnan(row))) for row in ts]
    steps = np.concatenate([s for s in steps if s.size]) if any(s.size for s in steps) else np.array([])
    period = float(np.median(steps)) if steps.size and np.median(steps) > 0 else float(np.median(
        np.diff(times) / np.diff(slots)))
    if not period > 0:
        raise ValueError("keypoints: frame timestamps do not advance (no frame period can be told)")
    offset = times - period * slots
    local = median_filter(offset, size=min(_GRID_WINDOW, offset.size), mode="nearest")
    held = period * slots + local + np.clip(offset - local, -_GRID_HOLD * period, _GRID_HOLD * period)
    if np.any(np.diff(held) <= 0):  # the offset itself jumps (a clock stepped): the straight grid
        held = period * slots + float(np.median(offset))
    moved = int(np.sum(np.abs(held - times) > 0.5))
    log.warning("frame times do not increase from frame set to frame set: %d of %d frame sets held to their "
                "frame grid (period %.3f ms; a camera stamped frames more than half a period off their slots)",
                moved, times.size, period / 1e6)
    return held, moved


def read_keypoints(path: str | os.PathLike, cameras: list[str] | None = None) -> MultiViewKeypoints:
    """All keypoints, frame sets aligned by frame id; cameras in calibration order (else sorted).

    A camera whose frame counter restarted within the recording (a camera or camera node restarted) has
    its later frames placed by timestamp (:mod:`gaitcap.acquisition.recording.frame_slots`), with a warning.
    Keypoint messages with a frame id far outside the recording (or a timestamp far from their frame's)
    are ignored and counted: nothing is allocated for them. Keypoint messages that cannot be read (not
    JSON, a field missing, of the wrong kind or out of bounds: :mod:`gaitcap.acquisition.keypoint_message`;
    people with another number of joints than the others) are ignored and counted with why, never refusing
    the recording; both per camera in ``ignored``."""
    per_cam: dict[str, list[tuple[int, int, np.ndarray, str]]] = {}
    unplaceable: dict[str, list[int]] = {}  # frame ids or stamps no frame grid can hold: stray at once
    unreadable: dict[str, dict[str, int]] = {}
    for topic, message in iter_messages(path, layout.is_keypoints_topic):
        camera = layout.camera_of_topic(topic)
        try:
            msg = parse_keypoint_message(message.data, camera=camera)
        except KeypointMessageError as exc:
            unreadable.setdefault(camera, {}).setdefault(exc.reason, 0)
            unreadable[camera][exc.reason] += 1
            continue
        fid, ts, skeleton, ppl = msg.frame_id, msg.timestamp_ns, msg.skeleton, msg.people
        if abs(fid) >= _MAX_FRAME_ID or not 0 <= ts < 2**63:
            unplaceable.setdefault(camera, []).append(fid)
            continue
        per_cam.setdefault(camera, []).append((fid, ts, ppl, skeleton))
    per_cam = _one_joint_count(per_cam, unreadable)
    if not per_cam:
        raise NoKeypointsRecorded(f"{path}: no keypoints recorded" + (
            f" with a usable frame id and timestamp ({sum(map(len, unplaceable.values()))} messages have a "
            "frame id beyond +-2**53 or a timestamp outside 0..2**63 ns)" if unplaceable else "") + (
            f"; keypoint messages that could not be read: {unreadable}" if unreadable else ""))
    for cam, whys in sorted(unreadable.items()):  # said here too: gaitcap process has no quality record
        log.warning("%s: camera %s: %d keypoint message(s) could not be read and were ignored (%s)", path, cam,
                    sum(whys.values()), ", ".join(f"{n} {why}" for why, n in sorted(whys.items())))
    for cam, fids in sorted(unplaceable.items()):  # never reach frame_slots, which says the other strays
        log.warning("%s: camera %s: %d keypoint message(s) with a frame id beyond +-2**53 or a timestamp outside "
                    "0..2**63 ns were ignored (from frame id %d)", path, cam, len(fids), fids[0])
    slotted, report, skeletons = _on_one_grid(per_cam)
    if len(skeletons) != 1:
        raise ValueError(f"{path}: keypoints of several skeletons {sorted(skeletons)}")
    strays = {c: report.strays.get(c, ()) + tuple(unplaceable.get(c, ())) for c in {*report.strays, *unplaceable}}
    names = _camera_order(path, slotted, cameras, strays, unreadable)
    fids = [f for cam in slotted.values() for f in cam]
    first, last = min(fids), max(fids)  # at most 2 x the frame sets + SLACK_FRAMES apart (frame_slots)
    frame_ids = np.arange(first, last + 1)
    most = max((len(p) for cam in slotted.values() for _, p in cam.values()), default=0)
    skeleton = skeletons.pop()
    joints = next((p.shape[1] for cam in slotted.values() for _, p in cam.values() if len(p)),
                  get_skeleton(skeleton).num_joints)
    people = missing_keypoints((len(names), frame_ids.size, most, joints))
    stamps = np.full((len(names), frame_ids.size), -1, dtype=np.int64)
    for c, name in enumerate(names):
        for fid, (ts, ppl) in slotted.get(name, {}).items():
            stamps[c, fid - first] = ts
            if len(ppl):
                people[c, fid - first, : len(ppl)] = ppl
    return MultiViewKeypoints(people, tuple(names), frame_times_s(stamps), skeleton, frame_ids=frame_ids,
                              timestamps_ns=stamps, restarts=report.restarts,
                              ignored=_ignored(strays, report, unreadable))


def _ignored(strays: dict[str, tuple[int, ...]], report: SlotReport,
             unreadable: dict[str, dict[str, int]]) -> dict[str, IgnoredKeypoints]:
    """{camera: its messages left out} from its stray frame ids (in time order) and unreadable counts."""
    return {c: IgnoredKeypoints.of(strays.get(c, ()), mistimed=len(report.in_span(strays.get(c, ()))),
                                   unreadable=unreadable.get(c)) for c in sorted({*strays, *unreadable})}


def _one_joint_count(per_cam: dict[str, list[tuple[int, int, np.ndarray, str]]],
                     unreadable: dict[str, dict[str, int]]) -> dict[str, list[tuple[int, int, np.ndarray, str]]]:
    """The messages whose people have the joint count most messages have; the others counted in
    ``unreadable`` (one malformed message must not refuse the recording). Cameras left without any are
    dropped."""
    counts: dict[int, int] = {}
    for rows in per_cam.values():
        for row in rows:
            if len(row[2]):
                counts[row[2].shape[1]] = counts.get(row[2].shape[1], 0) + 1
    if len(counts) < 2:
        return per_cam
    joints = max(counts, key=lambda j: (counts[j], -j))
    out = {}
    for cam, rows in per_cam.items():
        keep = [row for row in rows if not len(row[2]) or row[2].shape[1] == joints]
        for row in rows:
            if len(row[2]) and row[2].shape[1] != joints:
                why = f"people with {row[2].shape[1]} joints where the others have {joints}"
                unreadable.setdefault(cam, {}).setdefault(why, 0)
                unreadable[cam][why] += 1
        if keep:
            out[cam] = keep
    return out


def _on_one_grid(per_cam: dict[str, list[tuple[int, int, np.ndarray, str]]]
                 ) -> tuple[dict[str, dict[int, tuple[int, np.ndarray]]], SlotReport, set[str]]:
    """{camera: {frame set id: (timestamp ns, people)}} with restarted frame counters placed by time and
    frame ids far outside the recording left out; and the skeletons of the messages kept."""
    series = {cam: (np.array([e[0] for e in rows], dtype=np.int64), np.array([e[1] for e in rows], dtype=np.int64))
              for cam, rows in per_cam.items()}
    placed, report = align_frame_slots(series)
    out, skeletons = {}, set()
    for cam, (keep, slots) in placed.items():
        rows = per_cam[cam]
        if keep.size:  # a camera whose every frame id is far outside the recording has none
            out[cam] = {int(slot): (rows[i][1], rows[i][2]) for i, slot in zip(keep.tolist(), slots.tolist(), strict=True)}
            skeletons.update(rows[i][3] for i in keep.tolist())
    return out, report, skeletons


def _camera_order(path, per_cam: dict, cameras: list[str] | None, strays: dict[str, tuple[int, ...]],
                  unreadable: dict[str, dict[str, int]]) -> list[str]:
    if cameras is not None:
        unknown = sorted(set(cameras) - set(per_cam))
        if unknown:
            far = [c for c in unknown if c in strays]
            bad = {c: unreadable[c] for c in unknown if c in unreadable}
            raise ValueError(f"{path}: no keypoints recorded for cameras {unknown}"
                             + (f" (those of {far} all have frame ids far outside the recording)" if far else "")
                             + (f" (keypoint messages that could not be read: {bad})" if bad else ""))
        return list(cameras)
    try:
        order = [n for n in read_calibration(path).names if n in per_cam]
    except ValueError:
        order = []
    return order + sorted(set(per_cam) - set(order))


def read_detections(path: str | os.PathLike, cameras: list[str] | None = None) -> MultiViewKeypoints:
    """The patient's keypoints (P == 1, with the frame facts) as reconstruction input."""
    return read_keypoints(path, cameras).patient()
