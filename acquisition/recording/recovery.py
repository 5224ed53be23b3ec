"""Recover a recording cut short by a crash: every complete chunk of ``<path>.part`` into a valid MCAP.

The recorder writes ``<path>.part`` and renames it when the trial ends; a recorder that died leaves the
``.part`` file, and :func:`recover` keeps every intact chunk of it.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass
from pathlib import Path

from gaitcap.acquisition.recording import layout
from gaitcap.acquisition.recording.reader import (
    ScanState,
    is_complete,
    iter_messages,
    resolve_recording,
    scan,
)
from gaitcap.acquisition.recording.rewrite import rewrite_scanned

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class RecoveryReport:
    """What :func:`recover` found and wrote."""

    source: Path
    output: Path | None
    was_complete: bool
    chunks: int
    corrupt_chunks: int
    messages: dict[str, int]
    error: str | None


def recover(path: str | os.PathLike, out: str | os.PathLike | None = None) -> RecoveryReport:
    """Read every complete chunk of a recording cut short and write them as a valid MCAP.

    ``out`` defaults to the recording's final name (``x.mcap`` for ``x.mcap.part``; ``x.recovered.mcap``
    for a complete file with a corrupt chunk); a complete, intact file is only checked (no output
    written). ValueError when nothing readable is in the file.
    """
    src = resolve_recording(path)
    if is_complete(src):
        counts: dict[str, int] = {}
        try:
            for topic, _ in iter_messages(src, lambda t: True):
                counts[topic] = counts.get(topic, 0) + 1
            return RecoveryReport(src, None, True, 0, 0, counts, None)
        except ValueError as exc:  # complete but with a corrupt chunk: rewrite the intact ones
            log.warning("%s", exc)
    default = src.with_name(src.name.removesuffix(layout.PART_SUFFIX))
    if default == src:
        default = src.with_name(src.stem + ".recovered.mcap")
    target = Path(out) if out is not None else default
    if target == src or target.exists():
        raise ValueError(f"recover: output {target} exists (or is the input); give another path")
    state = ScanState(src)
    counts = rewrite_scanned(scan(src, state), state, target)
    if not counts:
        target.unlink(missing_ok=True)
        raise ValueError(f"{src}: no complete chunk could be read ({state.error})")
    return RecoveryReport(src, target, False, state.chunks, state.corrupt_chunks, counts, state.error)


CUT_SUFFIX = ".cut"


def finalise_cut(part: str | os.PathLike) -> dict:
    """Recover a ``<x>.mcap.part`` left by a recorder that died into ``<x>.mcap`` (complete chunks kept)
    and keep the cut original as ``<x>.mcap.part.cut``. Returns a JSON-ready report (``error`` set, and
    the ``.part`` left in place, when nothing could be recovered)."""
    part = Path(part)
    target = part.with_name(part.name.removesuffix(layout.PART_SUFFIX))
    try:
        if target.exists():
            raise ValueError(f"{target} exists already; {part.name} left as it is")
        rep = recover(part, target)
        part.rename(part.with_name(part.name + CUT_SUFFIX))
    except (ValueError, OSError) as exc:
        log.error("could not recover %s: %s", part, exc)
        return {"source": str(part), "path": str(target), "error": str(exc)}
    kept = sum(rep.messages.values())
    log.warning("recovered %s: %d chunks, %d messages kept (cut: %s)", target, rep.chunks, kept, rep.error)
    return {"source": str(part), "path": str(target), "chunks": rep.chunks, "corrupt_chunks": rep.corrupt_chunks,
            "messages": kept, "cut": rep.error, "error": None}
