"""Trial integrity in the catalog: compare-and-set transitions under concurrency (separate connections
to one SQLite file or PostgreSQL database), the crash states and their ways out, the data-quality record."""

import queue
import threading

import pytest
from gaitcap.services import catalog as cat
from gaitcap.services.catalog.states import ALLOWED, FINISHED, TrialState


@pytest.fixture
def db(catalog_url):
    c = cat.open_catalog(catalog_url)
    yield c
    c.close()


def _start(db, subject="P001"):
    return cat.start_trial(db, subject_id=subject, session="visit1", recording_path_for=lambda t: f"/d/{t}.mcap")


def _stop_once(url: str, trial_id: str, barrier, out) -> None:
    """What a Stop request does first: win recording -> stopping, then stopping -> recorded with a job."""
    db = cat.open_catalog(url)
    barrier.wait()
    try:
        cat.set_state(db, trial_id, "stopping", expect="recording")
        cat.set_state(db, trial_id, "recorded", expect="stopping", enqueue=True)
        out.put(("won", ""))
    except cat.IllegalTransition as exc:
        out.put(("lost", str(exc)))
    finally:
        db.close()


def test_concurrent_stops_on_separate_connections_make_exactly_one_job(db, catalog_url):
    t = _start(db)
    n = 8
    barrier, out = threading.Barrier(n), queue.Queue()
    procs = [threading.Thread(target=_stop_once, args=(catalog_url, t.id, barrier, out))
             for _ in range(n)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(60)
    results = sorted(out.get(timeout=5)[0] for _ in range(n))
    assert results == ["lost"] * (n - 1) + ["won"]
    assert cat.get_trial(db, t.id).state == "recorded"
    assert [j.state for j in cat.jobs_for_trial(db, t.id)] == ["queued"]
    assert cat.current_recording(db) is None  # the slot is free again


def test_stopping_keeps_the_recording_slot(db):
    t = _start(db)
    cat.set_state(db, t.id, "stopping", expect="recording")
    with pytest.raises(cat.RecordingBusy):
        _start(db, "P002")
    cat.set_state(db, t.id, "interrupted", error="recorder lost")
    assert cat.current_recording(db) is None
    assert _start(db, "P003").state == "recording"


def test_crash_path_interrupted_recovered_processed_with_warnings(db):
    t = _start(db)
    cat.set_state(db, t.id, "interrupted", error="recorder restarted")
    with pytest.raises(cat.IllegalTransition, match="from interrupted to processing"):
        cat.set_state(db, t.id, "processing")
    cat.set_state(db, t.id, "recovered", expect="interrupted", enqueue=True)
    assert cat.lease_job(db, "w1") is not None
    for state in ("processing", "done_with_warnings", "recorded"):  # re-queued (patient chosen anew)
        cat.set_state(db, t.id, state)


def test_every_state_has_a_way_out_to_an_end():
    finished = {s for s in TrialState if s in FINISHED}
    for state in TrialState:
        seen, todo = set(), [state]
        while todo:
            s = todo.pop()
            seen.add(s)
            todo += [n for n in ALLOWED[s] if n not in seen]
        assert seen & finished, f"{state} never reaches a finished state"


def test_unknown_fields_and_states_are_refused(db):
    t = _start(db)
    with pytest.raises(ValueError, match="'colour'"):
        cat.set_state(db, t.id, "failed", colour="red")
    with pytest.raises(cat.IllegalTransition, match="unknown state"):
        cat.set_state(db, t.id, "paused")
    with pytest.raises(cat.TrialNotFound):
        cat.set_state(db, "T-none", "failed")


def test_quality_sections_merge_and_warnings_come_in_order(db):
    t = _start(db)
    cat.set_quality(db, t.id, "processing", {"warnings": ["3 of 10 cameras below 28 fps"]})
    cat.set_quality(db, t.id, "recovery", {"warnings": ["the recorder stopped at 4.2 s"], "chunks": 3})
    q = cat.get_quality(db, t.id)
    assert q["recovery"]["chunks"] == 3
    assert cat.warnings_of(q) == ["the recorder stopped at 4.2 s", "3 of 10 cameras below 28 fps"]
    with pytest.raises(ValueError, match="section"):
        cat.set_quality(db, t.id, "mood", {})
