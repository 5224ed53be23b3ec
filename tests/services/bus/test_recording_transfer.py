"""A recording fetched from its room's recorder over the secured bus (real processes: the recorder node as
its own process on a TLS bus with access control; the worker on its own Zenoh session): chunk by chunk,
verified by the SHA-256 taken at Stop, byte for byte the room's file; a camera's identity may not fetch; a
wrong checksum keeps nothing; the recorder killed mid-fetch fails the trial naming the room and the trial,
with no file, whole or partial, left on the worker's host."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from gaitcap.services import catalog as cat
from gaitcap.services.bus import recording_transfer
from gaitcap.services.bus.certs import make_bus_keys
from gaitcap.services.bus.recording_transfer import RecordingFetchError
from gaitcap.services.bus.security import BusSecurity
from gaitcap.services.bus.session import BusConfig, free_loopback_ports
from gaitcap.services.catalog import rooms
from gaitcap.services.processing.room_fetch import RoomFetch, fetch_from_room
from gaitcap.services.processing.store import recording_checksum
from gaitcap.services.processing.worker import Worker, WorkerConfig

ROOT = Path(__file__).resolve().parents[3]
TRIAL = "T1"
CHUNK = 64 << 10


@pytest.fixture
def room(tmp_path):
    """Room gait2's recorder as a process on a secured bus, serving its finished recording of TRIAL."""
    bus = BusConfig({"recorder": f"tls/127.0.0.1:{free_loopback_ports(1)[0]}"}, prefix="gaitcap/gait2",
                    security=BusSecurity(tmp_path / "keys", clients=("worker-fetch", "camera-9")))
    make_bus_keys({n: bus.nodes.get(n) for n in bus.identities}, tmp_path / "keys")
    bus_file = tmp_path / "bus.json"
    bus_file.write_text(json.dumps(bus.to_dict()))
    data = tmp_path / "room2"
    recording = data / "trials" / TRIAL / f"{TRIAL}.mcap"
    recording.parent.mkdir(parents=True)
    recording.write_bytes(os.urandom(CHUNK * 7 + 1234))  # the transfer does not read what it carries
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-c", "from gaitcap.services.cli import main; main()", "node",
                             "recorder", "--bus", str(bus_file), "--data-dir", str(data)], env=env, cwd=str(ROOT),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        yield bus, recording, proc
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=20)


def _trial(db, recording: Path) -> cat.TrialInfo:
    rooms.register_room(db, "gait2", host="room2")
    t = cat.start_trial(db, subject_id="P1", session="s1", trial_id=TRIAL, room="gait2",
                        recording_path_for=lambda tid: f"/room2-host-only/trials/{tid}/{tid}.mcap")  # not here
    cat.set_quality(db, t.id, "recorder", {"frames": 10, **recording_checksum(recording)})
    cat.set_state(db, t.id, "recorded", enqueue=True)
    return cat.get_trial(db, t.id)


def _left(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.rglob("*") if p.is_file()) if folder.exists() else []


def test_a_worker_fetches_the_recording_from_the_rooms_recorder_and_a_dead_recorder_fails_it_plainly(
        room, tmp_path, monkeypatch):
    bus, recording, proc = room
    db = cat.open_catalog(tmp_path / "catalog.sqlite")
    trial = _trial(db, recording)
    stop = cat.get_quality(db, TRIAL)["recorder"]
    fetch = RoomFetch(buses={"gait2": bus}, node="worker-fetch", timeout_s=20.0, chunk_bytes=CHUNK)

    fetched = fetch_from_room(trial, stop, fetch, tmp_path / "fetched" / f"{TRIAL}.mcap")  # 8 chunks
    assert fetched.read_bytes() == recording.read_bytes()

    with pytest.raises(RecordingFetchError, match="room gait2, trial T1: the room's recorder has .* bytes, the "
                                                  "catalog recorded"):
        fetch_from_room(trial, {**stop, "bytes": stop["bytes"] + 1}, fetch, tmp_path / "wrong" / "x.mcap")
    with pytest.raises(RecordingFetchError, match="room gait2, trial T1: the fetched recording has SHA-256 .* not kept"):
        fetch_from_room(trial, {**stop, "sha256": "0" * 64}, fetch, tmp_path / "wrong" / "x.mcap")
    camera = RoomFetch(buses={"gait2": bus}, node="camera-9", timeout_s=1.0, chunk_bytes=CHUNK)
    with pytest.raises(RecordingFetchError, match="room gait2, trial T1: the room's recorder did not answer"):
        fetch_from_room(trial, stop, camera, tmp_path / "wrong" / "x.mcap")  # a camera may not ask for it
    assert _left(tmp_path / "wrong") == []

    real_ask, asked = recording_transfer._ask, []

    def ask_then_kill(*args, **kwargs):  # the room's host goes down after the worker has 3 chunks
        if len(asked) == 3:
            proc.kill()
            proc.wait(timeout=10)
        asked.append(args[3])
        return real_ask(*args, **kwargs)

    monkeypatch.setattr(recording_transfer, "_ask", ask_then_kill)
    worker_dir = tmp_path / "worker-host"
    t0 = time.monotonic()
    worker = Worker(WorkerConfig(catalog_url=db.url, data_dir=worker_dir,
                                 fetch=RoomFetch(buses={"gait2": bus}, node="worker-fetch", timeout_s=2.0,
                                                 chunk_bytes=CHUNK)), db=db)
    assert worker.run_once()
    assert time.monotonic() - t0 < 20
    failed = cat.get_trial(db, TRIAL)
    assert failed.state == "failed", failed
    assert failed.error.startswith(f"room gait2, trial T1: the room's recorder did not answer within 2 s at byte "
                                   f"{3 * CHUNK} of {stop['bytes']}"), failed.error
    assert "nothing was kept" in failed.error
    assert [j.state for j in cat.jobs_for_trial(db, TRIAL)] == ["failed"]
    assert not [n for n in _left(worker_dir) if ".mcap" in n]  # no recording, whole or partial
    db.close()
