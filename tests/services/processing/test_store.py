"""Workers anywhere: a worker on another host finds a room's recording in its mount of the shared store,
checked against the checksum taken at Stop (a changed or short copy is refused, naming both), takes over a
trial whose worker died, and writes the same gait JSON, byte for byte, as a one-room run on SQLite."""

import time
from pathlib import Path

import pytest
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import rooms
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.processing.store import RecordingMismatch, locate_recording, recording_checksum
from gaitcap.services.processing.worker import Worker, WorkerConfig

from ..conftest import write_trial_mcap


@pytest.fixture(scope="module")
def walk():
    from gaitcap.simulator import make_trial

    return make_trial("clean", seconds=6, cameras=4, people=1, seed=5, fps=30)


def _trial(trial_id: str, recording: Path) -> cat.TrialInfo:
    now = time.time()
    return cat.TrialInfo(trial_id, "P1", "s1", "recorded", now, now, now, now, str(recording), None, "", 0.0, "",
                         room="gait2")


def test_the_store_copy_is_found_and_must_match_the_checksum(tmp_path, walk):
    made = write_trial_mcap(walk, tmp_path / "room" / "trials" / "T1" / "recording.mcap")
    stop = recording_checksum(made)
    store = tmp_path / "mounted-elsewhere"
    copy = store / "trials" / "T1" / "recording.mcap"
    copy.parent.mkdir(parents=True)
    copy.write_bytes(made.read_bytes())
    away = _trial("T1", Path("/room-host-only/trials/T1/recording.mcap"))  # the path on the room's host
    assert locate_recording(away, stop, store=store) == copy
    assert locate_recording(_trial("T1", made), stop, store=store) == made  # where the catalog says, when here
    with pytest.raises(ValueError, match="T1: its recording /room-host-only/trials/T1/recording.mcap does not exist"):
        locate_recording(away, stop)
    data = bytearray(copy.read_bytes())
    data[len(data) // 2] ^= 0xFF
    copy.write_bytes(bytes(data))
    with pytest.raises(RecordingMismatch, match=f"T1: {copy} has SHA-256 .* the room recorded {stop['sha256'][:16]}"):
        locate_recording(away, stop, store=store)
    copy.write_bytes(bytes(data[:-100]))
    with pytest.raises(RecordingMismatch, match="still arriving or cut short"):
        locate_recording(away, stop, store=store)


def _gait_json(data_dir: Path, trial_id: str) -> bytes:
    return trial_files(data_dir, trial_id).stage_file("preliminary", "gait_json").read_bytes()


def test_a_worker_elsewhere_takes_over_a_dead_workers_trial_and_writes_the_one_room_result(tmp_path, walk, postgres,
                                                                                        monkeypatch):
    monkeypatch.setenv("GAITCAP_OPENSIM_DIR", str(tmp_path / "no-opensim"))  # kinematics said unavailable: not
    # what this test is about (tests/services/test_kinematics.py runs them), and half its time
    one_room = cat.open_catalog(tmp_path / "one-room" / "catalog.sqlite")
    t = cat.start_trial(one_room, subject_id="P1", session="s1", trial_id="T-same",
                        recording_path_for=lambda tid: tmp_path / "one-room" / f"{tid}.mcap")
    write_trial_mcap(walk, Path(t.recording_path))
    cat.set_state(one_room, t.id, "recorded", enqueue=True)
    Worker(WorkerConfig(catalog_url=one_room.url, data_dir=tmp_path / "one-room", refine=False), db=one_room).run_once()
    assert cat.get_trial(one_room, t.id).state == "done"

    central = cat.open_catalog(postgres.create_database("workers_anywhere"))
    rooms.register_room(central, "gait2", host="room2")
    room_host = tmp_path / "room2-host-only"  # the room's own path: not on the worker's host
    t2 = cat.start_trial(central, subject_id="P1", session="s1", trial_id="T-same", room="gait2",
                         recording_path_for=lambda tid: room_host / "trials" / tid / "recording.mcap")
    store = tmp_path / "store-mount"
    copy = store / "trials" / t2.id / "recording.mcap"
    copy.parent.mkdir(parents=True)
    copy.write_bytes(Path(t.recording_path).read_bytes())
    cat.set_quality(central, t2.id, "recorder", {"frames": 180, **recording_checksum(copy)})
    cat.set_state(central, t2.id, "recorded", enqueue=True)
    dead = cat.lease_job(central, "worker-that-died", lease_s=0.3)  # took the trial, started, then died
    cat.set_state(central, t2.id, "processing", expect="recorded", stage="starting")
    assert cat.lease_job(central, "gpu-server", lease_s=30) is None  # its lease still runs
    time.sleep(0.4)
    elsewhere = Worker(WorkerConfig(catalog_url=central.url, data_dir=tmp_path / "gpu-server", refine=False,
                                    store=store, worker_id="gpu-server"), db=central)
    assert elsewhere.run_once()
    job = cat.jobs_for_trial(central, t2.id)[0]
    assert (job.id, job.state, job.worker_id, job.attempts) == (dead.id, "done", "gpu-server", 2)
    assert cat.get_trial(central, t2.id).state == "done"
    assert _gait_json(tmp_path / "gpu-server", t2.id) == _gait_json(tmp_path / "one-room", t.id)
    assert cat.get_result(central, t2.id).summary == cat.get_result(one_room, t.id).summary
    central.close()
    one_room.close()
