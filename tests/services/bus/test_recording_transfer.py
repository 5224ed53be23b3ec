"""A recording fetched from its room's recorder over the secured bus (real processes: the recorder node as
its own process on a TLS bus with access control; the worker on its own Zenoh session): chunk by chunk,
verified by the SHA-256 taken at Stop, byte for byte the room's file. What cannot pass fails at once, named
(a recording absent from the recorder, one of another size, an identity the bus would refuse, which the bus
does refuse); what may pass is tried again: the recorder killed mid-fetch and started again, the worker's
trial finishes done; killed for good, the trial fails once the retry bound has passed, naming the room, the
trial and the last error. No file, whole or partial, is ever left on the worker's host but the verified copy.

The worker's processing after the fetch is stubbed here (it is the one processing path, whatever brought
the recording: ``tests/services/processing/test_store.py`` runs it on a copy from the store)."""

import json
import logging
import os
import signal
import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import pytest
from gaitcap.services import catalog as cat
from gaitcap.services.bus import recording_transfer
from gaitcap.services.bus.certs import make_bus_keys
from gaitcap.services.bus.recording_transfer import Download, FetchTarget, RecordingFetchError
from gaitcap.services.bus.security import BusSecurity
from gaitcap.services.bus.session import BusConfig, free_loopback_ports, open_session
from gaitcap.services.catalog import rooms
from gaitcap.services.processing import room_fetch
from gaitcap.services.processing import worker as worker_module
from gaitcap.services.processing.room_fetch import RoomFetch, fetch_from_room, with_retries
from gaitcap.services.processing.store import recording_checksum
from gaitcap.services.processing.worker import Worker, WorkerConfig

ROOT = Path(__file__).resolve().parents[3]
CHUNK = 64 << 10
PATIENT = "P-4711"  # must appear in no log line of the fetch


class Room:
    """Room gait2's recorder as a process on a secured bus, serving the finished recordings written by
    :meth:`record`; :meth:`start` (again) and :meth:`kill` its process."""

    def __init__(self, tmp_path: Path) -> None:
        self.bus = BusConfig({"recorder": f"tls/127.0.0.1:{free_loopback_ports(1)[0]}"}, prefix="gaitcap/gait2",
                             security=BusSecurity(tmp_path / "keys", clients=("worker-fetch", "camera-9")))
        make_bus_keys({n: self.bus.nodes.get(n) for n in self.bus.identities}, tmp_path / "keys")
        self.bus_file = tmp_path / "bus.json"
        self.bus_file.write_text(json.dumps(self.bus.to_dict()))
        self.data = tmp_path / "room2"
        self.proc = None

    def record(self, trial_id: str, size: int) -> Path:
        recording = self.data / "trials" / trial_id / f"{trial_id}.mcap"
        recording.parent.mkdir(parents=True)
        recording.write_bytes(os.urandom(size))  # the transfer does not read what it carries
        return recording

    def start(self) -> None:
        self.proc = subprocess.Popen([sys.executable, "-c", "from gaitcap.services.cli import main; main()", "node",
                                      "recorder", "--bus", str(self.bus_file), "--data-dir", str(self.data)],
                                     env=dict(os.environ, PYTHONPATH=str(ROOT)), cwd=str(ROOT),
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    def kill(self) -> None:
        self.proc.kill()
        self.proc.wait(timeout=10)

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            self.proc.wait(timeout=20)


@pytest.fixture(scope="module")
def recorder_host(tmp_path_factory):
    room = Room(tmp_path_factory.mktemp("room"))
    room.record("T1", CHUNK * 7 + 1234)
    room.record("T3", CHUNK * 5)
    room.start()
    try:
        yield room
    finally:
        room.stop()


@pytest.fixture
def room(recorder_host):
    """The room's recorder, running (started again when a test before killed it)."""
    if recorder_host.proc.poll() is not None:
        recorder_host.start()
    return recorder_host


def _trial(db, trial_id: str, recording: Path | None, *, size: int = 0) -> cat.TrialInfo:
    rooms.register_room(db, "gait2", host="room2")
    t = cat.start_trial(db, subject_id=PATIENT, session="s1", trial_id=trial_id, room="gait2",
                        recording_path_for=lambda tid: f"/room2-host-only/trials/{tid}/{tid}.mcap")  # not here
    checksum = recording_checksum(recording) if recording else {"bytes": size, "sha256": "1" * 64}
    cat.set_quality(db, t.id, "recorder", {"frames": 10, **checksum})
    cat.set_state(db, t.id, "recorded", enqueue=True)
    return cat.get_trial(db, t.id)


def _left(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.rglob("*") if p.is_file()) if folder.exists() else []


def _retries(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == room_fetch.log.name and " attempt " in r.getMessage()]


def _fails_at_once(caplog, match: str, *args) -> None:
    """``fetch_from_room(*args)`` fails for good on its first attempt (no retry, whatever the bound)."""
    caplog.clear()
    with caplog.at_level(logging.INFO), pytest.raises(RecordingFetchError, match=match) as caught:
        fetch_from_room(*args)
    assert caught.value.permanent and _retries(caplog) == [], (caught.value, _retries(caplog))


def test_a_recording_is_fetched_whole_and_what_cannot_pass_fails_at_once_named(room, tmp_path, monkeypatch,
                                                                               caplog):
    db = cat.open_catalog(tmp_path / "catalog.sqlite")
    trial = _trial(db, "T1", room.data / "trials" / "T1" / "T1.mcap")
    stop = cat.get_quality(db, "T1")["recorder"]
    fetch = RoomFetch(buses={"gait2": room.bus}, node="worker-fetch", timeout_s=20.0, chunk_bytes=CHUNK, retry_s=60)

    fetched = fetch_from_room(trial, stop, fetch, tmp_path / "fetched" / "T1.mcap")  # 8 chunks
    assert fetched.read_bytes() == (room.data / "trials" / "T1" / "T1.mcap").read_bytes()

    wrong = tmp_path / "wrong" / "x.mcap"
    absent = _trial(db, "T2", None, size=1000)  # in the catalog, not on this recorder
    _fails_at_once(caplog, "room gait2, trial T2: the room's recorder refused: trial T2: no finished recording "
                           "T2.mcap here",
                   absent, cat.get_quality(db, "T2")["recorder"], fetch, wrong)
    _fails_at_once(caplog, "room gait2, trial T1: the room's recorder has .* bytes, the catalog recorded",
                   trial, {**stop, "bytes": stop["bytes"] + 1}, fetch, wrong)
    camera = RoomFetch(buses={"gait2": room.bus}, node="camera-9", timeout_s=20.0, chunk_bytes=CHUNK, retry_s=60)
    _fails_at_once(caplog, r"room gait2, trial T1: access refused: .* as camera-9 \(role camera\), which may not "
                           "fetch",
                   trial, stop, camera, wrong)
    _fails_at_once(caplog, "room gait1: no bus is configured", replace(trial, room="gait1"), stop, fetch, wrong)
    session = open_session(room.bus, "camera-9")  # and the bus itself refuses a camera's query
    try:
        target = FetchTarget("gait2", "T1", str(trial.recording_path), stop["bytes"], stop["sha256"])
        with pytest.raises(RecordingFetchError, match="room gait2, trial T1: the room's recorder did not answer"):
            Download(target, tmp_path / "camera.part").attempt(session, room.bus.keys, timeout_s=0.5)
    finally:
        session.close()

    monkeypatch.setattr(room_fetch, "FIRST_PAUSE_S", 0.05)  # a copy failing its checksum is fetched again ...
    caplog.clear()
    with caplog.at_level(logging.INFO), pytest.raises(
            RecordingFetchError, match=r"room gait2, trial T1: the fetched recording has SHA-256 .* \(3 copies in a "
                                       r"row\): not kept") as caught:
        fetch_from_room(trial, {**stop, "sha256": "0" * 64}, fetch, wrong)
    assert caught.value.permanent  # ... but 3 in a row are not the recording made
    assert [m.split(" failed")[0] for m in _retries(caplog)] == [
        f"room gait2, trial T1: fetching the recording, attempt {n}" for n in (1, 2)]
    assert _left(tmp_path / "wrong") == []
    db.close()


def test_pauses_grow_and_the_bound_counts_from_the_last_new_byte():
    target = FetchTarget("gait2", "T1", "/x/T1.mcap", 10, "0" * 64)
    slept, had = [], iter([0, 0, 5, 5, 5, 5, 5, 5, 5, 5, 5, 5])
    clock = [0.0]
    calls = []

    def attempt():
        calls.append(next(had))
        raise target.error("the room's recorder is not on its bus")

    def sleep(s):
        slept.append(s)
        clock[0] += s

    with pytest.raises(RecordingFetchError, match=r"room gait2, trial T1: gave up after 9 attempts over 21.5 s "
                                                  r"\(20 s without a new byte, the fetch's retry bound\); the last: "
                                                  "the room's recorder is not on its bus; nothing was kept") as caught:
        with_retries(attempt, target, retry_s=20, progressed=lambda: calls[-1] if calls else 0, sleep=sleep,
                     clock=lambda: clock[0])
    assert not caught.value.permanent
    assert slept[:3] == [0.5, 1.0, 0.5]  # the third attempt got new bytes: the pauses start again
    assert slept[3:6] == [1.0, 2.0, 4.0] and max(slept) <= 10.0
    assert sum(slept[2:]) == pytest.approx(20.0)  # 20 s from the new byte, not from the first attempt


def test_the_recorder_killed_mid_fetch_is_waited_for_and_a_room_gone_for_good_fails_the_trial_named(
        room, tmp_path, monkeypatch, caplog):
    db = cat.open_catalog(tmp_path / "catalog.sqlite")
    _trial(db, "T1", room.data / "trials" / "T1" / "T1.mcap")
    monkeypatch.setattr(worker_module, "recording_input", lambda path, **kw: SimpleNamespace(path=path))
    monkeypatch.setattr(worker_module, "process_trial",
                        lambda data, options, **kw: SimpleNamespace(quality=SimpleNamespace(serious=False)))
    real_ask, asked = recording_transfer._ask, []

    def ask_then_kill(*args, **kwargs):  # the room's host goes down after the worker has 3 chunks ...
        if len(asked) == 3:
            room.kill()
            if restart:
                room.start()  # ... and comes back
        asked.append(args[3])
        return real_ask(*args, **kwargs)

    monkeypatch.setattr(recording_transfer, "_ask", ask_then_kill)
    worker_dir = tmp_path / "worker-host"
    killed = worker_dir / "trials" / "T1" / ".T1.mcap.x8f3k2.mcap"  # a worker killed mid-fetch left it
    killed.parent.mkdir(parents=True)
    killed.write_bytes(b"half a recording")
    config = WorkerConfig(catalog_url=db.url, data_dir=worker_dir,
                          fetch=RoomFetch(buses={"gait2": room.bus}, node="worker-fetch", timeout_s=2.0,
                                          chunk_bytes=CHUNK, retry_s=60.0))
    restart = True
    with caplog.at_level(logging.INFO):
        assert Worker(config, db=db).run_once()
    done = cat.get_trial(db, "T1")
    assert done.state == "done", done
    fetched = worker_dir / "trials" / "T1" / "T1.mcap"
    assert fetched.read_bytes() == (room.data / "trials" / "T1" / "T1.mcap").read_bytes()
    assert asked[:4] == [0, CHUNK, 2 * CHUNK, 3 * CHUNK] and asked.count(0) == 1  # resumed, not started again
    retried = _retries(caplog)
    assert retried and all(m.startswith("room gait2, trial T1: fetching the recording, attempt ") for m in retried)
    assert not [r for r in caplog.records if PATIENT in r.getMessage()]

    asked.clear()
    restart = False  # the room gone for good
    _trial(db, "T3", room.data / "trials" / "T3" / "T3.mcap")
    assert Worker(WorkerConfig(catalog_url=db.url, data_dir=worker_dir,
                               fetch=RoomFetch(buses={"gait2": room.bus}, node="worker-fetch", timeout_s=0.5,
                                               chunk_bytes=CHUNK, retry_s=1.5)), db=db).run_once()
    failed = cat.get_trial(db, "T3")
    assert failed.state == "failed", failed
    assert failed.error.startswith("room gait2, trial T3: gave up after "), failed.error
    assert "(1.5 s without a new byte, the fetch's retry bound); the last: the room's recorder" in failed.error
    assert failed.error.endswith("nothing was kept"), failed.error
    assert [j.state for j in cat.jobs_for_trial(db, "T3")] == ["failed"]
    assert [n for n in _left(worker_dir) if ".mcap" in n] == ["T1.mcap"]  # T3's: neither whole nor partial; the killed fetch's: removed
    db.close()
