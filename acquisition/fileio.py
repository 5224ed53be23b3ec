"""Writing files so that a crash never leaves a half-written one: the one atomic writer of gaitcap.

Everything that writes a result, calibration, export or recording copy goes through :func:`atomic_path`
(a temporary name in the same folder, renamed onto the target on success, removed on failure). It lives in
``acquisition/``, the lowest layer that does I/O, so the recorder, the synthetic world and every service use
the same one; ``reconstruction/`` writes no files.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, *, fsync: bool = False) -> Iterator[Path]:
    """Yield a temporary path next to ``path`` (same suffix, so ``np.savez`` keeps it); when the block ends
    without error it is renamed onto ``path``, else removed and ``path`` keeps its old content (or stays
    absent). The folder is created if needed; ``fsync`` flushes the file to disk before the rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=path.suffix)
    os.close(fd)
    try:
        yield Path(tmp)
        if fsync:
            with open(tmp, "rb") as f:
                os.fsync(f.fileno())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def file_sha256(path: str | os.PathLike, *, chunk_bytes: int = 1 << 20) -> str:
    """The SHA-256 of the file's bytes (hex), read in chunks."""
    import hashlib

    digest = hashlib.sha256()
    with open(path, "rb") as f:
        while block := f.read(chunk_bytes):
            digest.update(block)
    return digest.hexdigest()


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; returns the path."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` to ``path`` atomically (no newline translation); returns the path."""
    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="") as f:
            f.write(text)
    return Path(path)


def atomic_savez(path: str | os.PathLike, **arrays: np.ndarray) -> Path:
    """Write ``arrays`` as an uncompressed NPZ file at ``path`` atomically; returns the path."""
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        np.savez(f, **arrays)
    return Path(path)
