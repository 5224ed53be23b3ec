"""A finished trial recording fetched from its room's recorder over the bus, for a worker without the rooms'
shared store (:mod:`gaitcap.services.processing.store`).

The recorder node serves its finished recordings on the queryable ``<prefix>/recorder/recording/<trial_id>``
(:meth:`Keys.recording <gaitcap.services.bus.keys.Keys.recording>`, :class:`RecordingServer`): a query carries
a :class:`~gaitcap.services.bus.messages.ChunkRequest` (the trial, the recording's file name, a byte offset
and length) and the reply carries those bytes, with a :class:`~gaitcap.services.bus.messages.ChunkReply`
attachment (the offset and the file's whole size, or the refusal). It serves only
``trials/<trial_id>/<name>.mcap`` inside its data folder (where the room's API has it record; the
recorder's own confinement, :func:`~gaitcap.services.nodes.recorder.confined_path`, applies), never one
being written (``.part``). On a secured bus only the worker and api roles may query it
(:mod:`gaitcap.services.bus.security`).

A :class:`Download` asks for the file chunk by chunk into a temporary file beside the target (the caller's
:func:`~gaitcap.acquisition.fileio.atomic_path`), hashing as it goes; it is complete only when the size and
SHA-256 match those the catalog recorded at Stop. A failed :meth:`Download.attempt` raises
:class:`RecordingFetchError` naming the room, the trial and how far it got, marked ``permanent`` when asking
again cannot help; otherwise the next attempt goes on from the byte it has (a copy that failed its checksum
starts again from the first byte). The retries, their pauses and their bound are the caller's
(:func:`gaitcap.services.processing.room_fetch.fetch_from_room`).
"""

from __future__ import annotations

import hashlib
import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from gaitcap.services.bus.keys import Keys
from gaitcap.services.bus.messages import MAX_CHUNK_BYTES, ChunkReply, ChunkRequest

log = logging.getLogger(__name__)

DEFAULT_CHUNK_BYTES = 1 << 20
#: A recording whose whole copy fails its checksum this many times is not the one recorded (the room's
#: file has changed since Stop): that failure is then permanent.
MAX_MISMATCHES = 3


class RecordingServer:
    """Serves the finished recordings under ``data_root`` on the bus (declared by the recorder node);
    ``resolve(relative path) -> Path`` confines a requested path to the data folder (ValueError otherwise)."""

    def __init__(self, session, keys: Keys, *, resolve: Callable[[str], Path]) -> None:
        self.resolve = resolve
        self._queryable = session.declare_queryable(keys.recording(), self._on_query)

    def chunk(self, request: ChunkRequest) -> tuple[bytes, ChunkReply]:
        """The bytes asked for; ValueError when there is no such finished recording here (asking again
        cannot help), OSError when it could not be read just now."""
        path = self.resolve(f"trials/{request.trial_id}/{request.name}")
        if not path.is_file():
            raise ValueError(f"trial {request.trial_id}: no finished recording {path.name} here")
        size = path.stat().st_size
        if request.offset > size:
            raise ValueError(f"trial {request.trial_id}: offset {request.offset} beyond the recording's {size} bytes")
        with open(path, "rb") as f:
            f.seek(request.offset)
            data = f.read(request.length)
        return data, ChunkReply(offset=request.offset, size=size)

    def _serve(self, query) -> None:
        try:
            request = ChunkRequest.from_bytes(query.payload.to_bytes() if query.payload else b"")
            if str(query.key_expr) != str(query.key_expr).rsplit("/", 1)[0] + "/" + request.trial_id:
                raise ValueError(f"{query.key_expr}: asks for trial {request.trial_id}'s recording")
            data, reply = self.chunk(request)
        except (ValueError, OSError) as exc:
            data, reply = b"", ChunkReply(error=str(exc), transient=isinstance(exc, OSError))
            log.warning("recording request on %s refused: %s", query.key_expr, exc)
        query.reply(query.key_expr, data, attachment=reply.to_bytes())

    def _on_query(self, query) -> None:
        threading.Thread(target=self._serve, args=(query,), daemon=True).start()  # off Zenoh's thread

    def close(self) -> None:
        self._queryable.undeclare()


class RecordingFetchError(ValueError):
    """The recording could not be fetched from its room's recorder (nothing was kept). ``permanent``:
    asking again cannot help (no such recording on that recorder, a refusal, access refused by the bus's
    roles, not the recording the catalog recorded); otherwise the recorder may answer later (unreachable or
    restarting, a chunk that timed out, a copy that failed its checksum). ``reason``: the message without
    the room and the trial."""

    def __init__(self, named: str, reason: str, *, permanent: bool = False) -> None:
        super().__init__(f"{named}: {reason}")
        self.reason, self.permanent = reason, permanent


@dataclass(frozen=True)
class FetchTarget:
    """What to fetch: trial ``trial_id`` of room ``room``, recorded at ``path`` (the catalog's path on the
    room's host), ``size`` bytes with SHA-256 ``sha256`` (taken at Stop)."""

    room: str
    trial_id: str
    path: str
    size: int
    sha256: str

    @property
    def named(self) -> str:
        return f"room {self.room or '(default)'}, trial {self.trial_id}"

    def error(self, reason: str, *, permanent: bool = False) -> RecordingFetchError:
        return RecordingFetchError(self.named, reason, permanent=permanent)


def _ask(session, keys: Keys, target: FetchTarget, offset: int, length: int, timeout_s: float) -> bytes:
    import zenoh

    request = ChunkRequest(trial_id=target.trial_id, name=Path(target.path).name, offset=offset, length=length)
    try:
        for reply in session.get(keys.recording(target.trial_id), payload=request.to_bytes(), timeout=timeout_s):
            return _chunk(reply, target, offset, length)
    except zenoh.ZError as exc:
        raise target.error(f"the bus failed asking for byte {offset}: {exc}") from None
    raise target.error(f"the room's recorder did not answer within {timeout_s:g} s at byte {offset} of "
                       f"{target.size} (is the room's recorder running, and its host up?)")


def _chunk(reply, target: FetchTarget, offset: int, length: int) -> bytes:
    if reply.ok is None:
        raise target.error(f"the recorder answered with an error at byte {offset}: "
                           f"{reply.err.payload.to_bytes().decode(errors='replace')[:200]}")
    try:
        meta = ChunkReply.from_bytes(reply.ok.attachment.to_bytes() if reply.ok.attachment else b"")
    except ValueError as exc:
        raise target.error(f"the recorder's reply at byte {offset} is malformed: {exc}") from None
    if meta.error:
        raise target.error(f"the room's recorder refused: {meta.error}", permanent=not meta.transient)
    if meta.size != target.size:
        raise target.error(f"the room's recorder has {meta.size} bytes, the catalog recorded {target.size} at "
                           "Stop: not the recording that was made", permanent=True)
    data = reply.ok.payload.to_bytes()
    if meta.offset != offset or len(data) != min(length, target.size - offset):
        raise target.error(f"the recorder sent {len(data)} bytes at {meta.offset} for {length} at {offset}")
    return data


class Download:
    """``target`` being fetched into ``tmp`` (a temporary file beside where it goes; removing it on failure
    is the caller's): each :meth:`attempt` goes on from ``offset``, the bytes it has; ``complete`` once the
    whole recording is there and matches the checksum taken at Stop."""

    def __init__(self, target: FetchTarget, tmp: Path, *, chunk_bytes: int = DEFAULT_CHUNK_BYTES) -> None:
        if not 1 <= chunk_bytes <= MAX_CHUNK_BYTES:
            raise ValueError(f"chunk_bytes: must be in [1, {MAX_CHUNK_BYTES}], got {chunk_bytes}")
        self.target, self.tmp, self.chunk_bytes = target, Path(tmp), chunk_bytes
        self.offset, self.complete, self.mismatches = 0, False, 0
        self._digest = hashlib.sha256()

    def attempt(self, session, keys: Keys, *, timeout_s: float = 10.0,
                progress: Callable[[int, int], None] | None = None) -> None:
        """Ask for the rest of the recording (``progress(bytes so far, size)`` after each chunk) and check it;
        RecordingFetchError otherwise. A whole copy that fails its checksum is dropped: the next attempt
        starts again from the first byte (the :data:`MAX_MISMATCHES`-th such copy fails for good)."""
        target = self.target
        mode = "ab" if self.offset else "wb"
        with open(self.tmp, mode) as out:
            while self.offset < target.size or (self.offset == 0 and target.size == 0):
                data = _ask(session, keys, target, self.offset, self.chunk_bytes, timeout_s)
                out.write(data)
                self._digest.update(data)
                self.offset += len(data)
                if progress is not None:
                    progress(self.offset, target.size)
                if not data:
                    break
        got = self._digest.hexdigest()
        if got != target.sha256:
            self.offset, self.mismatches, self._digest = 0, self.mismatches + 1, hashlib.sha256()
            times = f" ({self.mismatches} copies in a row)" if self.mismatches > 1 else ""
            raise target.error(f"the fetched recording has SHA-256 {got[:16]}..., the room recorded "
                               f"{target.sha256[:16]}...{times}: not kept",
                               permanent=self.mismatches >= MAX_MISMATCHES)
        self.complete = True
        log.info("%s: recording fetched from the room's recorder (%d bytes, checksum verified)", target.named,
                 self.offset)
