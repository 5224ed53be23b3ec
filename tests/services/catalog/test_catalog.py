"""The catalog on a real SQLite file and a real PostgreSQL database: state machine, the single recording slot, results, audit, schema."""

import threading

import pytest
from gaitcap.services import catalog as cat
from gaitcap.services.catalog.models import SCHEMA_VERSION, SchemaInfo
from sqlalchemy import update


@pytest.fixture
def db(catalog_url):
    c = cat.open_catalog(catalog_url)
    yield c
    c.close()


def _start(db, subject="P001", session="visit1"):
    return cat.start_trial(db, subject_id=subject, session=session, recording_path_for=lambda t: f"/d/{t}.mcap")


def test_trial_walks_the_state_machine(db):
    t = _start(db)
    assert t.state == "recording" and t.recording_path.endswith(f"{t.id}.mcap") and t.session == "visit1"
    for state in ("recorded", "processing", "done"):
        t = cat.set_state(db, t.id, state)
    assert cat.get_trial(db, t.id).state == "done"
    with pytest.raises(cat.IllegalTransition, match="from done to processing"):
        cat.set_state(db, t.id, "processing")


@pytest.mark.parametrize("path", [("recording", "done"), ("recording", "processing"), ("recorded", "done")])
def test_illegal_transitions_raise(db, path):
    t = _start(db)
    if path[0] == "recorded":
        cat.set_state(db, t.id, "recorded")
    with pytest.raises(cat.IllegalTransition, match=t.id):
        cat.set_state(db, t.id, path[1])


def test_expect_guards_the_current_state(db):
    t = _start(db)
    with pytest.raises(cat.IllegalTransition, match="expected processing"):
        cat.set_state(db, t.id, "done", expect="processing")


def test_only_one_trial_records_at_a_time(db):
    t = _start(db)
    with pytest.raises(cat.RecordingBusy, match=t.id):
        _start(db, subject="P002")
    cat.set_state(db, t.id, "recorded")
    assert _start(db, subject="P002").state == "recording"


def test_concurrent_starts_from_two_connections_give_one_trial(catalog_url):
    path = catalog_url
    cat.open_catalog(path).close()
    outcomes, barrier = [], threading.Barrier(4)

    def go(i):
        c = cat.open_catalog(path)
        barrier.wait()
        try:
            outcomes.append(_start(c, subject=f"P{i}").id)
        except cat.RecordingBusy:
            outcomes.append("busy")
        finally:
            c.close()

    threads = [threading.Thread(target=go, args=(i,)) for i in range(4)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert sorted(outcomes).count("busy") == 3


def test_ids_are_validated(db):
    for bad in ("../etc", "a/b", "", "x" * 65, "a b", ".hidden"):
        with pytest.raises(ValueError, match="subject_id"):
            cat.start_trial(db, subject_id=bad, session="s1")
    with pytest.raises(ValueError, match="trial_id"):
        cat.get_trial(db, "../../x")
    with pytest.raises(cat.TrialNotFound, match="T123"):
        cat.get_trial(db, "T123")


def test_results_with_steps_and_summary_round_trip(db):
    t = _start(db)
    steps = [{"side": "left", "time_s": 1.0, "step_length_mm": 600.0}, {"side": "right", "time_s": 1.5}]
    cat.store_result(db, trial_id=t.id, stage="preliminary", method="robust", steps=steps,
                     summary={"cadence_steps_per_min": 110.0, "step_length_mm": {"mean": 600, "sd": 20, "unit": "mm"}})
    r = cat.get_result(db, t.id)
    assert r.stage == "preliminary" and r.steps == steps
    assert r.summary["step_length_mm"] == {"mean": 600.0, "sd": 20.0, "unit": "mm"}
    cat.store_result(db, trial_id=t.id, stage="refined", method="implicit", steps=steps[:1], summary={})
    assert cat.get_result(db, t.id).stage == "refined"
    assert len(cat.get_result(db, t.id, "preliminary").steps) == 2
    cat.store_result(db, trial_id=t.id, stage="refined", method="implicit", steps=[], summary={})  # replace
    assert cat.get_result(db, t.id).steps == [] and sorted(cat.stages_available(db, t.id)) == ["preliminary", "refined"]
    with pytest.raises(ValueError, match="stage"):
        cat.store_result(db, trial_id=t.id, stage="final", method="", steps=[], summary={})


def test_audit_log_records_who_did_what(db):
    t = _start(db)
    cat.audit(db, actor="dr_a", action="start", trial_id=t.id)
    cat.audit(db, actor="dr_b", action="download", trial_id=t.id, detail="steps.csv")
    got = cat.audit_entries(db, trial_id=t.id)
    assert [(e.actor, e.action) for e in got] == [("dr_b", "download"), ("dr_a", "start")]


def test_schema_version_mismatch_is_refused(catalog_url):
    path = catalog_url
    c = cat.open_catalog(path)
    assert cat.schema_version(c) == SCHEMA_VERSION == 6
    with c.session() as s:
        s.execute(update(SchemaInfo).where(SchemaInfo.key == "version").values(value="999"))
    c.close()
    with pytest.raises(cat.SchemaMismatch, match="999"):
        cat.open_catalog(path)


def test_calibrations_are_stored(db):
    assert cat.latest_calibration(db) is None
    cid = cat.add_calibration(db, toml="[cam_0]\nname = 'a'\n", source="test")
    assert cat.latest_calibration(db) == (cid, "[cam_0]\nname = 'a'\n")
    with pytest.raises(ValueError, match="toml"):
        cat.add_calibration(db, toml="  ")


def test_processes_opening_a_new_catalog_at_once_all_open_it(fresh_catalog_url):
    """A stack's API and workers (or two rooms) open the same new catalog at the same moment: each opens it,
    tables made once (PostgreSQL: concurrent CREATE TABLEs collided before the opening lock)."""
    outcomes, barrier = [], threading.Barrier(4)

    def go():
        barrier.wait()
        try:
            c = cat.open_catalog(fresh_catalog_url)
            outcomes.append(cat.schema_version(c))
            c.close()
        except Exception as exc:  # noqa: BLE001 - the outcome is what the test checks
            outcomes.append(repr(exc))

    threads = [threading.Thread(target=go) for _ in range(4)]
    for th in threads:
        th.start()
    for th in threads:
        th.join(60)
    assert outcomes == [SCHEMA_VERSION] * 4
