"""Where a worker finds a trial's recording, and the proof that it is the file the room recorded.

The catalog keeps the path the room's recorder wrote (``trials.recording_path``) and, from Stop, the
recording's SHA-256 and size (the ``recorder`` section of the trial's quality record: ``sha256``, ``bytes``).
A worker on another host reads it at that path when the shared store is mounted at the same place, else in
its own mount of the store (``store``: the folder holding ``trials/<trial_id>/``, as every room's data
folder does). Whichever file it finds must match the checksum: a copy still being written, cut short or
changed is refused with both checksums named, never processed.
"""

from __future__ import annotations

from pathlib import Path

from gaitcap.acquisition.fileio import file_sha256
from gaitcap.services.catalog import TrialInfo


class RecordingMismatch(ValueError):
    """The file found is not the recording the room wrote (checksum or size differ)."""


class RecordingNotFound(ValueError):
    """The recording is on none of the places this host looked (it may be fetched from its room's recorder)."""


def candidates(trial: TrialInfo, store: Path | None) -> list[Path]:
    """Where the trial's recording may be, in order: the catalog's path, then the store's
    ``trials/<trial_id>/<file name>``."""
    if not trial.recording_path:
        raise ValueError(f"trial {trial.id}: the catalog records no recording path")
    recorded = Path(trial.recording_path)
    found = [recorded]
    if store is not None:
        found.append(Path(store) / "trials" / trial.id / recorded.name)
    return found


def locate_recording(trial: TrialInfo, recorder: dict, *, store: Path | None = None) -> Path:
    """The trial's recording on this host, checked against the checksum in ``recorder`` (the quality record's
    ``recorder`` section; a trial recorded before checksums has none and is taken as found). ValueError
    naming the trial and where it looked when there is none; RecordingMismatch when it differs."""
    places = candidates(trial, store)
    path = next((p for p in places if p.is_file()), None)
    if path is None and store is None:
        raise RecordingNotFound(f"trial {trial.id}: its recording {places[0]} does not exist")
    if path is None:
        raise RecordingNotFound(f"trial {trial.id}: its recording is in none of {', '.join(map(str, places))} "
                         "(is the shared store mounted on this host?)")
    expected, size = recorder.get("sha256"), recorder.get("bytes")
    if size is not None and path.stat().st_size != int(size):
        raise RecordingMismatch(f"trial {trial.id}: {path} has {path.stat().st_size} bytes, the room recorded "
                                f"{int(size)} (a copy still arriving or cut short?)")
    if expected:
        got = file_sha256(path)
        if got != expected:
            raise RecordingMismatch(f"trial {trial.id}: {path} has SHA-256 {got[:16]}..., the room recorded "
                                    f"{expected[:16]}...: not the recording that was made")
    return path


def recording_checksum(path: Path) -> dict:
    """What Stop records of a finished recording: ``{"sha256": ..., "bytes": ...}``."""
    return {"sha256": file_sha256(path), "bytes": Path(path).stat().st_size}
