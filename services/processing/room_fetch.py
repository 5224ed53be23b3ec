"""A worker without the rooms' shared store gets a trial's recording from its room's recorder over that
room's (secured) bus (:mod:`gaitcap.services.bus.recording_transfer`), into its own data folder at
``trials/<trial_id>/<file name>``, checked against the size and SHA-256 the catalog recorded at Stop.

``gaitcap worker --fetch-bus ROOM=BUSFILE`` (one per room) names each room's bus; the worker joins it as
``--fetch-node`` (a ``worker-*`` identity of that bus file, whose role may query recordings and nothing else).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path

from gaitcap.services.bus.recording_transfer import DEFAULT_CHUNK_BYTES, FetchTarget, RecordingFetchError
from gaitcap.services.bus.session import BusConfig
from gaitcap.services.catalog import TrialInfo
from gaitcap.services.processing.store import RecordingNotFound, locate_recording

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class RoomFetch:
    """Where recordings are fetched from: ``buses`` room name -> its bus; ``node`` the identity the worker
    joins each as; ``timeout_s`` how long a chunk (and the recorder's appearance on the bus) may take;
    ``chunk_bytes`` each request's size."""

    buses: dict[str, BusConfig] = field(default_factory=dict)
    node: str = "worker-fetch"
    timeout_s: float = 10.0
    chunk_bytes: int = DEFAULT_CHUNK_BYTES

    def __post_init__(self) -> None:
        if self.timeout_s <= 0:
            raise ValueError(f"timeout_s: must be > 0 s, got {self.timeout_s}")

    def bus_of(self, room: str) -> BusConfig:
        if room not in self.buses:
            shown = room or "(default)"
            raise RecordingFetchError(f"room {shown}: no bus is configured to fetch its recordings from "
                                      f"(gaitcap worker --fetch-bus {room or 'ROOM'}=BUSFILE); known: "
                                      f"{sorted(self.buses) or 'none'}")
        return self.buses[room]


def _target(trial: TrialInfo, recorder: dict) -> FetchTarget:
    if not recorder.get("sha256") or recorder.get("bytes") is None:
        raise RecordingFetchError(f"room {trial.room or '(default)'}, trial {trial.id}: the catalog holds no "
                                  "checksum of its recording (recorded before checksums): a fetched copy could "
                                  "not be verified")
    return FetchTarget(room=trial.room, trial_id=trial.id, path=str(trial.recording_path),
                       size=int(recorder["bytes"]), sha256=str(recorder["sha256"]))


def _wait_for_recorder(session, bus: BusConfig, target: FetchTarget, timeout_s: float) -> None:
    from gaitcap.services.bus.session import alive_nodes

    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if "recorder" in alive_nodes(session, bus, timeout_s=0.5):
            return
        time.sleep(0.1)
    raise RecordingFetchError(f"{target.named}: the room's recorder is not on its bus (waited {timeout_s:g} s; "
                              "is its host up?)")


def fetch_from_room(trial: TrialInfo, recorder: dict, fetch: RoomFetch, into: Path) -> Path:
    """Fetch the trial's recording from its room's recorder into ``into`` (verified; nothing left on failure)."""
    from gaitcap.services.bus.recording_transfer import fetch_recording
    from gaitcap.services.bus.session import open_session

    target = _target(trial, recorder)
    bus = fetch.bus_of(trial.room)
    session = open_session(bus, fetch.node)
    try:
        _wait_for_recorder(session, bus, target, fetch.timeout_s)
        return fetch_recording(session, bus.keys, target, into, chunk_bytes=fetch.chunk_bytes,
                               timeout_s=fetch.timeout_s)
    finally:
        session.close()


def find_recording(trial: TrialInfo, recorder: dict, *, store: Path | None, fetch: RoomFetch | None,
                   data_dir: Path) -> Path:
    """The trial's verified recording on this host: where the catalog says or in the store
    (:func:`~gaitcap.services.processing.store.locate_recording`); else, with ``fetch``, a copy fetched
    earlier into ``data_dir`` or one fetched now from the room's recorder."""
    try:
        return locate_recording(trial, recorder, store=store)
    except RecordingNotFound:
        if fetch is None:
            raise
    try:
        return locate_recording(trial, recorder, store=data_dir)  # fetched before (a retried job)
    except RecordingNotFound:
        pass
    into = Path(data_dir) / "trials" / trial.id / Path(str(trial.recording_path)).name
    log.info("room %s, trial %s: fetching the recording from the room's recorder", trial.room or "(default)",
             trial.id)
    return fetch_from_room(trial, recorder, fetch, into)
