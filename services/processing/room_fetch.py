"""A worker without the rooms' shared store gets a trial's recording from its room's recorder over that
room's (secured) bus (:mod:`gaitcap.services.bus.recording_transfer`), into its own data folder at
``trials/<trial_id>/<file name>``, checked against the size and SHA-256 the catalog recorded at Stop.

``gaitcap worker --fetch-bus ROOM=BUSFILE`` (one per room) names each room's bus; the worker joins it as
``--fetch-node`` (a ``worker-*`` identity of that bus file, whose role may query recordings and nothing else).

A fetch that fails for a reason that may pass (the room's recorder not on its bus, unreachable or
restarting; a chunk that timed out; a copy that failed its checksum) is tried again, each attempt going on
from the bytes it has, after pauses of ``FIRST_PAUSE_S`` doubling up to ``MAX_PAUSE_S``, each logged with the
room and the trial; it fails for good once ``RoomFetch.retry_s`` seconds (``--fetch-retry-s``) have passed
without a new byte of the recording arriving, with a reason naming the room, the trial, the attempts and
the last error. A failure that cannot pass (no such recording on that recorder, the recorder's refusal,
this worker's identity not allowed to fetch, a recording of another size than the catalog's) fails at
once. Until the copy is whole and verified it is a temporary file beside its place, removed on any failure
(and, left by a worker killed mid-fetch, when the recording is fetched again).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from gaitcap.acquisition.fileio import atomic_path
from gaitcap.services.bus.recording_transfer import (
    DEFAULT_CHUNK_BYTES,
    Download,
    FetchTarget,
    RecordingFetchError,
)
from gaitcap.services.bus.session import BusConfig
from gaitcap.services.catalog import TrialInfo
from gaitcap.services.processing.store import RecordingNotFound, locate_recording

log = logging.getLogger(__name__)

FIRST_PAUSE_S = 0.5  # the pause before the second attempt; doubled after each failed attempt ...
MAX_PAUSE_S = 10.0  # ... up to this
DEFAULT_RETRY_S = 120.0  # a room host rebooting, a recorder restarted by systemd


@dataclass(frozen=True)
class RoomFetch:
    """Where recordings are fetched from: ``buses`` room name -> its bus; ``node`` the identity the worker
    joins each as; ``timeout_s`` how long a chunk (and the recorder's appearance on the bus) may take;
    ``chunk_bytes`` each request's size; ``retry_s`` how long a failing fetch is tried again without a new
    byte of the recording arriving before the trial fails (s)."""

    buses: dict[str, BusConfig] = field(default_factory=dict)
    node: str = "worker-fetch"
    timeout_s: float = 10.0
    chunk_bytes: int = DEFAULT_CHUNK_BYTES
    retry_s: float = DEFAULT_RETRY_S

    def __post_init__(self) -> None:
        if self.timeout_s <= 0:
            raise ValueError(f"timeout_s: must be > 0 s, got {self.timeout_s}")
        if self.retry_s < 0:
            raise ValueError(f"retry_s: must be >= 0 s, got {self.retry_s}")

    def bus_of(self, room: str) -> BusConfig:
        if room not in self.buses:
            shown = room or "(default)"
            raise RecordingFetchError(f"room {shown}", "no bus is configured to fetch its recordings from "
                                      f"(gaitcap worker --fetch-bus {room or 'ROOM'}=BUSFILE); known: "
                                      f"{sorted(self.buses) or 'none'}", permanent=True)
        return self.buses[room]


def _target(trial: TrialInfo, recorder: dict) -> FetchTarget:
    target = FetchTarget(room=trial.room, trial_id=trial.id, path=str(trial.recording_path),
                         size=int(recorder.get("bytes") or 0), sha256=str(recorder.get("sha256") or ""))
    if not recorder.get("sha256") or recorder.get("bytes") is None:
        raise target.error("the catalog holds no checksum of its recording (recorded before checksums): a "
                           "fetched copy could not be verified", permanent=True)
    return target


def _check_access(bus: BusConfig, node: str, target: FetchTarget) -> None:
    """Refuse at once an identity the room's bus would not let fetch (its queries would go unanswered)."""
    from gaitcap.services.bus.security import may_send, role_of

    key = bus.keys.recording(target.trial_id).removeprefix(f"{bus.keys.prefix}/")  # as the bus's roles name it
    if bus.security is not None and not may_send(node, "query", key):
        raise target.error(f"access refused: this worker joins the room's bus as {node} (role {role_of(node)}), "
                           "which may not fetch recordings; use a worker-* identity (--fetch-node) listed in the "
                           "bus file's security.clients", permanent=True)


def _wait_for_recorder(session, bus: BusConfig, target: FetchTarget, timeout_s: float) -> None:
    from gaitcap.services.bus.session import alive_nodes

    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if "recorder" in alive_nodes(session, bus, timeout_s=0.5):
            return
        time.sleep(0.1)
    raise target.error(f"the room's recorder is not on its bus (waited {timeout_s:g} s; is its host up?)")


def with_retries(attempt: Callable[[], None], target: FetchTarget, *, retry_s: float,
                 progressed: Callable[[], int], sleep: Callable[[float], None] = time.sleep,
                 clock: Callable[[], float] = time.monotonic) -> None:
    """Call ``attempt`` until it returns; after a RecordingFetchError that may pass, again after a pause
    (``FIRST_PAUSE_S`` doubling up to ``MAX_PAUSE_S``), each logged; ``progressed()``: the most bytes any
    attempt has had so far (a new high restarts the ``retry_s`` clock and the pauses). Raises the permanent
    error at once, and a RecordingFetchError naming the attempts and the last error once ``retry_s`` has
    passed without progress."""
    attempts, pause, best = 0, FIRST_PAUSE_S, progressed()
    since = first = clock()
    while True:
        attempts += 1
        try:
            return attempt()
        except RecordingFetchError as exc:
            if exc.permanent:
                raise
            if progressed() > best:
                best, since, pause = progressed(), clock(), FIRST_PAUSE_S
            left = retry_s - (clock() - since)
            if left <= 0:
                raise target.error(f"gave up after {attempts} attempt{'s' if attempts > 1 else ''} over "
                                   f"{clock() - first:.1f} s ({retry_s:g} s without a new byte, the "
                                   f"fetch's retry bound); the last: {exc.reason}; nothing was kept") from None
            wait = min(pause, left)
            log.warning("%s: fetching the recording, attempt %d failed: %s; trying again in %.1f s (for %.1f s "
                        "more without a new byte)", target.named, attempts, exc.reason, wait, left)
            sleep(wait)
            pause = min(2 * pause, MAX_PAUSE_S)


def _remove_leftovers(target: FetchTarget, into: Path) -> None:
    """Remove the temporary copies of ``into`` that a worker killed mid-fetch left beside it (the names
    :func:`~gaitcap.acquisition.fileio.atomic_path` gives them)."""
    for left in Path(into).parent.glob(f".{Path(into).name}.*{Path(into).suffix}"):
        log.warning("%s: removing %s, a partial copy left by a fetch that was cut off", target.named, left.name)
        left.unlink(missing_ok=True)


def fetch_from_room(trial: TrialInfo, recorder: dict, fetch: RoomFetch, into: Path) -> Path:
    """Fetch the trial's recording from its room's recorder into ``into`` (verified; retried while the
    failure may pass, for ``fetch.retry_s`` without progress; nothing left at ``into`` or beside it on failure)."""
    from gaitcap.services.bus.session import open_session

    target = _target(trial, recorder)
    bus = fetch.bus_of(trial.room)
    _check_access(bus, fetch.node, target)
    try:
        session = open_session(bus, fetch.node)
    except ValueError as exc:  # this host's keys or the bus file: asking again cannot help
        raise target.error(f"cannot join the room's bus: {exc}", permanent=True) from None
    try:
        _remove_leftovers(target, into)
        with atomic_path(into) as tmp:
            download = Download(target, tmp, chunk_bytes=fetch.chunk_bytes)

            def attempt() -> None:
                _wait_for_recorder(session, bus, target, fetch.timeout_s)
                download.attempt(session, bus.keys, timeout_s=fetch.timeout_s)

            with_retries(attempt, target, retry_s=fetch.retry_s, progressed=lambda: download.offset)
        return Path(into)
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
