"""A finished trial recording fetched from its room's recorder over the bus, for a worker without the rooms'
shared store (:mod:`gaitcap.services.processing.store`).

The recorder node serves its finished recordings on the queryable ``<prefix>/recorder/recording/<trial_id>``
(:class:`RecordingServer`): a query carries a :class:`ChunkRequest` (the trial, the recording's file name,
a byte offset and length) and the reply carries those bytes, with a :class:`ChunkReply` attachment (the
offset and the file's whole size, or the refusal). It serves only ``trials/<trial_id>/<name>.mcap`` inside
its data folder (where the room's API has it record; the recorder's own confinement,
:func:`~gaitcap.services.nodes.recorder.confined_path`, applies), never one being written (``.part``). On a secured bus only the worker and api roles may
query it (:mod:`gaitcap.services.bus.security`).

:func:`fetch_recording` asks for the file chunk by chunk into a temporary file beside the target, hashing
as it goes, and moves it into place only when the size and SHA-256 match those the catalog recorded at Stop;
a recorder that stops answering, a refusal or a mismatch raises :class:`RecordingFetchError` naming the room,
the trial and how far it got, and leaves nothing behind.
"""

from __future__ import annotations

import hashlib
import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

from gaitcap.acquisition.fileio import atomic_path
from gaitcap.services.bus.keys import Keys, check_name
from gaitcap.services.bus.messages import _int, _Json, _str

log = logging.getLogger(__name__)

MAX_CHUNK_BYTES = 8 << 20  # a reply carries at most this many bytes
DEFAULT_CHUNK_BYTES = 1 << 20
MAX_FILE_BYTES = 1 << 46


def recording_key(keys: Keys, trial_id: str = "*") -> str:
    """``<prefix>/recorder/recording/<trial_id>`` (``*``: every trial's, the server's queryable)."""
    return f"{keys.prefix}/recorder/recording/{trial_id if trial_id == '*' else check_name(trial_id, what='trial')}"


@dataclass(frozen=True)
class ChunkRequest(_Json):
    """``length`` bytes from ``offset`` of trial ``trial_id``'s recording ``name`` (its file name)."""

    what: ClassVar[str] = "recording chunk request"
    trial_id: str
    name: str
    offset: int
    length: int

    def __post_init__(self) -> None:
        check_name(self.trial_id, what=f"{self.what}.trial_id")
        if not check_name(self.name, what=f"{self.what}.name").endswith(".mcap"):
            raise ValueError(f"{self.what}.name: {self.name!r} is not an .mcap file name")
        _int(self.offset, f"{self.what}.offset", 0, MAX_FILE_BYTES)
        _int(self.length, f"{self.what}.length", 1, MAX_CHUNK_BYTES)


@dataclass(frozen=True)
class ChunkReply(_Json):
    """The attachment of a chunk's reply: its ``offset`` and the recording's ``size`` (bytes), or ``error``."""

    what: ClassVar[str] = "recording chunk reply"
    offset: int = 0
    size: int = 0
    error: str | None = None

    def __post_init__(self) -> None:
        _int(self.offset, f"{self.what}.offset", 0, MAX_FILE_BYTES)
        _int(self.size, f"{self.what}.size", 0, MAX_FILE_BYTES)
        _str(self.error, f"{self.what}.error", 2000, optional=True)


class RecordingServer:
    """Serves the finished recordings under ``data_root`` on the bus (declared by the recorder node);
    ``resolve(relative path) -> Path`` confines a requested path to the data folder (ValueError otherwise)."""

    def __init__(self, session, keys: Keys, *, resolve: Callable[[str], Path]) -> None:
        self.resolve = resolve
        self._queryable = session.declare_queryable(recording_key(keys), self._on_query)

    def chunk(self, request: ChunkRequest) -> tuple[bytes, ChunkReply]:
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
            data, reply = b"", ChunkReply(error=str(exc))
            log.warning("recording request on %s refused: %s", query.key_expr, exc)
        query.reply(query.key_expr, data, attachment=reply.to_bytes())

    def _on_query(self, query) -> None:
        threading.Thread(target=self._serve, args=(query,), daemon=True).start()  # off Zenoh's thread

    def close(self) -> None:
        self._queryable.undeclare()


class RecordingFetchError(ValueError):
    """The recording could not be fetched from its room's recorder (nothing was kept)."""


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


def _ask(session, keys: Keys, target: FetchTarget, offset: int, length: int, timeout_s: float) -> bytes:
    request = ChunkRequest(trial_id=target.trial_id, name=Path(target.path).name, offset=offset, length=length)
    for reply in session.get(recording_key(keys, target.trial_id), payload=request.to_bytes(), timeout=timeout_s):
        if reply.ok is None:
            raise RecordingFetchError(f"{target.named}: the recorder answered with an error at byte {offset}: "
                                      f"{reply.err.payload.to_bytes().decode(errors='replace')[:200]}")
        meta = ChunkReply.from_bytes(reply.ok.attachment.to_bytes() if reply.ok.attachment else b"")
        if meta.error:
            raise RecordingFetchError(f"{target.named}: the room's recorder refused: {meta.error}")
        if meta.size != target.size:
            raise RecordingFetchError(f"{target.named}: the room's recorder has {meta.size} bytes, the catalog "
                                      f"recorded {target.size} at Stop: not the recording that was made")
        data = reply.ok.payload.to_bytes()
        if meta.offset != offset or len(data) != min(length, target.size - offset):
            raise RecordingFetchError(f"{target.named}: the recorder sent {len(data)} bytes at {meta.offset} "
                                      f"for {length} at {offset}")
        return data
    raise RecordingFetchError(f"{target.named}: the room's recorder did not answer within {timeout_s:g} s at byte "
                              f"{offset} of {target.size} (is the room's recorder running, and its host up?); "
                              "nothing was kept")


def fetch_recording(session, keys: Keys, target: FetchTarget, into: Path, *, chunk_bytes: int = DEFAULT_CHUNK_BYTES,
                    timeout_s: float = 10.0, progress: Callable[[int, int], None] | None = None) -> Path:
    """Fetch ``target`` from its room's recorder into ``into`` (moved into place only once whole and
    matching the catalog's size and SHA-256); ``progress(bytes so far, size)`` after each chunk.
    RecordingFetchError naming the room and the trial otherwise (no file left at ``into``)."""
    if not 1 <= chunk_bytes <= MAX_CHUNK_BYTES:
        raise ValueError(f"chunk_bytes: must be in [1, {MAX_CHUNK_BYTES}], got {chunk_bytes}")
    digest = hashlib.sha256()
    with atomic_path(into) as tmp, open(tmp, "wb") as out:
        offset = 0
        while offset < target.size or (offset == 0 and target.size == 0):
            data = _ask(session, keys, target, offset, chunk_bytes, timeout_s)
            out.write(data)
            digest.update(data)
            offset += len(data)
            if progress is not None:
                progress(offset, target.size)
            if not data:
                break
        out.flush()
        if digest.hexdigest() != target.sha256:
            raise RecordingFetchError(f"{target.named}: the fetched recording has SHA-256 {digest.hexdigest()[:16]}"
                                      f"..., the room recorded {target.sha256[:16]}...: not kept")
    log.info("%s: recording fetched from the room's recorder (%d bytes, checksum verified)", target.named, offset)
    return Path(into)
