"""The API's trial guard on a real catalog and real MCAP files: a recording whose recorder died is
interrupted within seconds, its cut file recovered and processed; a recording still under way after an
API restart is left alone; a Stop that died half-way is finished. The link stands in for the bus (it
reports the recorder's liveliness and status as the bus would)."""

import json
import time

import pytest
from gaitcap.acquisition.recording.writer import TrialWriter, WriterSettings
from gaitcap.services import catalog as cat
from gaitcap.services.live.guard import GuardTimes, TrialGuard
from gaitcap.services.live.nodes import NodeState

TIMES = GuardTimes(down_s=1.0, start_grace_s=15.0, stop_grace_s=30.0, recover_after_s=5.0, give_up_s=120.0)


class BusView:
    """What the bus tells the guard: the recorder's liveliness and its status reply."""

    def __init__(self):
        self.recorder: NodeState | None = None
        self.status: dict | None = None

    def nodes(self):
        return {} if self.recorder is None else {"recorder": self.recorder}

    def recorder_status(self):
        return self.status


@pytest.fixture
def db(tmp_path):
    c = cat.open_catalog(tmp_path / "catalog.sqlite")
    yield c
    c.close()


def _trial(db, tmp_path, subject="P001"):
    folder = tmp_path / "trials"
    folder.mkdir(exist_ok=True)
    return cat.start_trial(db, subject_id=subject, session="s1", recording_path_for=lambda t: folder / f"{t}.mcap")


def _cut_recording(path, frames=60):
    """A recording cut by a crash: chunks flushed to ``.part``, never finished."""
    writer = TrialWriter(path, WriterSettings(chunk_size_bytes=2000, flush_interval_s=0.01))
    writer.start(metadata={"trial_id": path.stem}, time_ns=1)
    for i in range(frames):
        kp = json.dumps({"camera": "cam0", "frame_id": i, "timestamp_ns": i * 33_000_000, "skeleton": "halpe26",
                         "people": [], "detector_ms": 0.0}).encode()
        writer.add_keypoints("cam0", kp, timestamp_ns=i * 33_000_000, frame_id=i)
        writer.flush()
    writer._file.close()  # the process died: nothing else is written
    return writer.part_path


def test_recorder_killed_mid_trial_interrupts_recovers_and_queues_processing(db, tmp_path):
    t = _trial(db, tmp_path)
    bus = BusView()
    guard = TrialGuard(db, bus, times=TIMES)
    now = t.started_at + 10
    bus.recorder = NodeState("recorder", False, now - 0.5, True)  # token lost half a second ago
    guard.check(now)
    assert cat.get_trial(db, t.id).state == "recording"  # not yet: could be a blip
    guard.check(now + 1.0)
    trial = cat.get_trial(db, t.id)
    assert trial.state == "interrupted" and "the recorder stopped at" in trial.error
    assert cat.current_recording(db) is None  # Start is possible again

    part = _cut_recording(tmp_path / "trials" / f"{t.id}.mcap")
    bus.recorder, bus.status = NodeState("recorder", True, now + 2, True), {"trial_id": None}
    guard.check(now + 3)  # the restarted recorder gets its chance to recover the file first
    assert cat.get_trial(db, t.id).state == "interrupted" and part.exists()
    guard.check(now + 8)  # it did not: the guard recovers it
    trial = cat.get_trial(db, t.id)
    assert trial.state == "recovered" and trial.error == ""
    assert (tmp_path / "trials" / f"{t.id}.mcap").is_file() and not part.exists()
    assert part.with_name(part.name + ".cut").is_file()  # the cut original is kept
    quality = cat.get_quality(db, t.id)["recovery"]
    assert quality["recovered"] is True and quality["messages"]
    assert quality["warnings"][0].startswith("The recorder stopped at")
    assert [j.state for j in cat.jobs_for_trial(db, t.id)] == ["queued"]


def test_a_restarted_recorder_that_already_recovered_the_file_is_followed(db, tmp_path):
    t = _trial(db, tmp_path)
    bus = BusView()
    guard = TrialGuard(db, bus, times=TIMES)
    bus.recorder, bus.status = NodeState("recorder", True, t.started_at + 4, True), {"trial_id": None}
    guard.check(t.started_at + 4.5)  # restarted faster than down_s: still noticed
    assert cat.get_trial(db, t.id).state == "interrupted"
    from gaitcap.acquisition.recording.recovery import finalise_cut

    assert finalise_cut(_cut_recording(tmp_path / "trials" / f"{t.id}.mcap"))["error"] is None  # the recorder
    guard.check(t.started_at + 5)
    assert cat.get_trial(db, t.id).state == "recovered"


def test_after_an_api_restart_a_recording_under_way_is_left_alone(db, tmp_path):
    t = _trial(db, tmp_path)
    bus = BusView()
    guard = TrialGuard(db, bus, times=TIMES)
    # the API (and its board) started after the recorder: the token was there already
    bus.recorder, bus.status = NodeState("recorder", True, t.started_at + 60, False), {"trial_id": t.id}
    guard.check(t.started_at + 61)
    assert cat.get_trial(db, t.id).state == "recording"
    bus.status = {"trial_id": None}  # Start still in flight (young trial, recorder not restarted): wait
    guard.check(t.started_at + 5)
    assert cat.get_trial(db, t.id).state == "recording"
    guard.check(t.started_at + 16)  # ... but not forever
    assert cat.get_trial(db, t.id).state == "interrupted"


def test_a_stop_that_died_half_way_is_finished(db, tmp_path):
    t = _trial(db, tmp_path)
    cat.set_state(db, t.id, "stopping", expect="recording")
    (tmp_path / "trials" / f"{t.id}.mcap").write_bytes(b"finished")
    bus = BusView()
    guard = TrialGuard(db, bus, times=TIMES)
    guard.check(time.time() + 5)
    assert cat.get_trial(db, t.id).state == "stopping"
    guard.check(time.time() + 31)
    assert cat.get_trial(db, t.id).state == "recorded"
    assert [j.state for j in cat.jobs_for_trial(db, t.id)] == ["queued"]


def test_an_interrupted_trial_without_any_file_fails_in_the_end(db, tmp_path):
    t = _trial(db, tmp_path)
    cat.set_state(db, t.id, "interrupted", error="the recorder stopped")
    bus = BusView()
    guard = TrialGuard(db, bus, times=TIMES)
    guard.check(time.time() + 121)
    trial = cat.get_trial(db, t.id)
    assert trial.state == "failed" and "no recording was found" in trial.error


def test_a_recording_with_no_recorder_ever_seen_is_interrupted_after_the_start_grace(db, tmp_path):
    t = _trial(db, tmp_path)
    bus = BusView()  # the API restarted while the recorder was down: no token at all
    guard = TrialGuard(db, bus, times=TIMES)
    guard.check(guard.started + 10)
    assert cat.get_trial(db, t.id).state == "recording"
    guard.check(guard.started + 16)
    trial = cat.get_trial(db, t.id)
    assert trial.state == "interrupted" and "no recorder is running" in trial.error
