"""A Stop written late (the catalog was unreachable when it was pressed) on a real catalog: a write cut off
half-way is finished by the next try, with one audit row, and a trial that moved on meanwhile is left as it
is."""

import time

import pytest
from gaitcap.services import catalog as cat
from gaitcap.services.live import pending_stops
from gaitcap.services.live.pending_stops import PendingStop, PendingStops


@pytest.fixture
def db(tmp_path):
    c = cat.open_catalog(tmp_path / "catalog.sqlite")
    yield c
    c.close()


def _recording(db, tmp_path, subject="P001"):
    path_for = lambda t: tmp_path / f"{t}.mcap"  # noqa: E731
    trial = cat.start_trial(db, subject_id=subject, session="s1", recording_path_for=path_for)
    (tmp_path / f"{trial.id}.mcap").write_bytes(b"recording")
    return trial


def test_a_stop_cut_off_half_way_is_finished_by_the_next_try(db, tmp_path, monkeypatch, caplog):
    trial = _recording(db, tmp_path)
    real, calls = pending_stops.finish_stop, []

    def cut_once(*args, **kwargs):  # the catalog goes away again after recording -> stopping
        calls.append(1)
        if len(calls) == 1:
            raise ConnectionError("the server closed the connection")
        return real(*args, **kwargs)

    monkeypatch.setattr(pending_stops, "finish_stop", cut_once)
    stops = PendingStops(db, period_s=60.0)
    stops.add(PendingStop(trial_id=trial.id, summary={"frames": 10}, actor="alice", stopped_at=time.time()))
    assert stops.flush() == 1 and cat.get_trial(db, trial.id).state == "stopping"
    assert f"trial {trial.id}: its Stop could not be written" in caplog.text  # not a lost catalog: named
    assert stops.flush() == 0
    assert cat.get_trial(db, trial.id).state == "recorded" and len(calls) == 2
    rows = [r for r in cat.audit_entries(db, trial_id=trial.id) if r.action == "stop"]
    assert len(rows) == 1 and rows[0].actor == "alice"
    assert cat.get_quality(db, trial.id)["recorder"]["bytes"] == len(b"recording")


def test_a_trial_that_moved_on_is_left_as_it_is(db, tmp_path):
    trial = _recording(db, tmp_path)
    cat.set_state(db, trial.id, "interrupted", expect="recording", error="the recorder died")
    stops = PendingStops(db, period_s=60.0)
    stops.add(PendingStop(trial_id=trial.id, summary={}, actor="alice", stopped_at=time.time()))
    assert stops.flush() == 0 and cat.get_trial(db, trial.id).state == "interrupted"
