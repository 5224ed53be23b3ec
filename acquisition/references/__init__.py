"""Readers of reference recordings for ``gaitcap validate``: C3D (ezc3d), TRC, an instrumented walkway's
CSV export. Each returns a :class:`gaitcap.reconstruction.validation.reference.Reference`; errors name the
file and what it lacks. ``read_reference(path)`` picks the reader by the file's suffix (``READERS``)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from gaitcap.acquisition.references.c3d import read_c3d
from gaitcap.acquisition.references.trc import read_trc
from gaitcap.acquisition.references.walkway import read_walkway
from gaitcap.reconstruction.validation.reference import Reference

#: suffix -> reader
READERS: dict[str, Callable[[Path], Reference]] = {".c3d": read_c3d, ".trc": read_trc, ".csv": read_walkway}


def read_reference(path: str | Path) -> Reference:
    """The reference in ``path`` (ValueError naming the file when it is missing or of an unknown kind)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"reference {path}: no such file")
    reader = READERS.get(path.suffix.lower())
    if reader is None:
        raise ValueError(f"reference {path}: unknown kind {path.suffix!r}, expected one of {', '.join(READERS)}")
    return reader(path)
