"""A catalog made by the previous release (schema 4, written by that release's own code:
data/catalog_v4.sql, made by make_catalog_v4.py) is upgraded in place when this gaitcap opens it: every
trial, state, stage result with its steps and summary, quality block, job, calibration version, patient
and trial detail, research row and audit row is kept; the new release writes to it; the page serves it."""

import sqlite3
from pathlib import Path

import httpx
from gaitcap.api.server import serve_in_thread
from gaitcap.api.settings import Settings
from gaitcap.services import catalog as cat
from gaitcap.services.access.accounts import AccountStore
from gaitcap.services.access.client import sign_in
from gaitcap.services.bus.session import free_loopback_ports
from gaitcap.services.catalog import calibration_versions as versions
from gaitcap.services.catalog import method_results as store
from gaitcap.services.catalog import patients
from gaitcap.services.catalog.models import SCHEMA_VERSION

V4_SQL = Path(__file__).parent / "data" / "catalog_v4.sql"
PASSWORD = "a-long-test-password"


def _v4_catalog(folder: Path) -> Path:
    path = folder / "catalog.sqlite"
    with sqlite3.connect(path) as con:
        con.executescript(V4_SQL.read_text())
    con.close()
    return path


def _rows(path: Path) -> dict[str, int]:
    with sqlite3.connect(path) as con:
        tables = [r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")]
        counts = {t: con.execute(f'SELECT count(*) FROM "{t}"').fetchone()[0] for t in tables}
    con.close()
    return counts


def test_a_catalog_of_the_previous_release_is_upgraded_in_place_and_served(tmp_path):
    path = _v4_catalog(tmp_path)
    before = _rows(path)
    assert before["trials"] == 4 and before["steps"] == 16
    with sqlite3.connect(path) as con:
        assert con.execute("SELECT value FROM schema_info WHERE key = 'version'").fetchone() == ("4",)
    con.close()

    db = cat.open_catalog(path, create=False)
    assert cat.schema_version(db) == SCHEMA_VERSION
    after = _rows(path)
    assert {t: after[t] for t in before} == before  # every row kept, in place
    trials = {t.id: t for t in cat.list_trials(db)}
    assert sorted(t.state for t in trials.values()) == ["done", "done_with_warnings", "failed", "recording"]
    done = next(t for t in trials.values() if t.state == "done")
    refined = cat.get_result(db, done.id)
    assert refined.stage == "refined" and len(refined.steps) == 4 and refined.steps[1]["side"] == "right"
    assert refined.summary["step_length_mm"]["mean"] == 601.5 and refined.artifacts["gait_json"].endswith("gait.json")
    warned = next(t for t in trials.values() if t.state == "done_with_warnings")
    assert cat.warnings_of(cat.get_quality(db, warned.id)) == ["cam_03: 12 frames missing"]
    assert patients.get_details(db, warned.id).walking_aid == "cane"
    failed = next(t for t in trials.values() if t.state == "failed")
    assert failed.error == "no keypoints recorded" and cat.jobs_for_trial(db, failed.id)[0].state == "failed"
    assert patients.get_patient(db, "P0042").birth_year == 1961
    cal = cat.latest_calibration(db)[0]
    assert len(versions.lineage(db, cal)) == 2
    assert store.get_result(db, done.id, "robust", "0123456789abcdef").metrics == {"GC_10": 0.8}
    assert {e.action for e in cat.audit_entries(db)} == {"start", "stop", "view", "correct"}

    # the new release writes to it: the trial left recording is stopped and processed
    left = next(t for t in trials.values() if t.state == "recording")
    cat.set_state(db, left.id, "interrupted", error="the old release was stopped mid-trial")
    cat.store_result(db, trial_id=done.id, stage="preliminary", method="robust triangulation", steps=[], summary={},
                     method_name="robust", params_key="00000000000000ab")
    assert store.get_result(db, done.id, "robust", "00000000000000ab").stage == "preliminary"
    db.close()

    AccountStore(tmp_path / "accounts.json").set("anna", password=PASSWORD, roles=("clinician",))
    settings = Settings(catalog_url=str(path), data_dir=tmp_path, port=free_loopback_ports(1)[0])
    srv = serve_in_thread(settings, None)
    try:
        with httpx.Client(base_url=srv.url, timeout=10) as client:
            sign_in(client, "anna", PASSWORD)
            served = {t["id"]: t["state"] for t in client.get("/trials").json()}
            assert served[done.id] == "done" and served[failed.id] == "failed" and len(served) == 4
            gait = client.get(f"/trials/{done.id}/gait").json()
            assert gait["stage"] == "refined" and gait["summary"]["step_length_mm"]["mean"] == 601.5
            assert client.get("/patients/P0042").status_code == 200
    finally:
        srv.stop()
