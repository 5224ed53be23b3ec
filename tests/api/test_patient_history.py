"""The patient history the REST API returns is built with a fixed number of SQL statements, whatever
the number of trials (counted on the catalog's engine), and carries each trial's best result."""

import contextlib

import pytest
from gaitcap.api.routes_patients import history_of
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import patients as pat
from gaitcap.services.reports.content import NORM_UNITS
from gaitcap.services.reports.norms import load_norms
from sqlalchemy import event


@pytest.fixture
def db(tmp_path):
    c = cat.open_catalog(tmp_path / "catalog.sqlite")
    yield c
    c.close()


def _summary(speed_m_s: float) -> dict:
    return {"gait_speed_m_per_s": {"mean": speed_m_s, "sd": 0.05, "unit": "m/s"},
            "cadence_steps_per_min": {"mean": 100.0, "sd": 2.0, "unit": "steps/min"}}


def _trials(db, subject: str, n: int) -> list[str]:
    """``n`` finished trials; each has a preliminary result, every other one a refined one too, every
    third one a void mark."""
    ids = []
    for i in range(n):
        t = cat.start_trial(db, subject_id=subject, session=f"v{i}", recording_path_for=lambda t: f"/d/{t}.mcap")
        cat.set_state(db, t.id, "recorded")
        cat.store_result(db, trial_id=t.id, stage="preliminary", method="dlt", steps=[], summary=_summary(1.0))
        if i % 2 == 0:
            cat.store_result(db, trial_id=t.id, stage="refined", method="implicit_fit", steps=[],
                             summary=_summary(1.0 + i / 100))
        if i % 3 == 0:
            pat.void_trial(db, t.id, by="alice", reason="wrong shoes")
        ids.append(t.id)
    pat.update_patient(db, subject, sex="male", birth_year=1956)
    return ids


@contextlib.contextmanager
def counted(db):
    statements: list[str] = []

    def count(conn, cursor, statement, *args):
        statements.append(statement)

    event.listen(db.engine, "before_cursor_execute", count)
    try:
        yield statements
    finally:
        event.remove(db.engine, "before_cursor_execute", count)


def test_history_queries_do_not_grow_with_the_trials(db):
    norms = load_norms(units=NORM_UNITS)
    counts = {}
    for subject, n in (("FEW", 3), ("MANY", 30)):
        ids = _trials(db, subject, n)
        p = pat.get_patient(db, subject)
        with counted(db) as statements:
            history = history_of(db, p, norms)
        counts[n] = len(statements)
        assert [h["id"] for h in history] == ids  # oldest first
        for h in history:  # the best result's means, as get_result picks it
            best = cat.get_result(db, h["id"]).summary
            assert h["values"] == {"gait_speed_m_s": best["gait_speed_m_per_s"]["mean"],
                                   "cadence_steps_min": best["cadence_steps_per_min"]["mean"]}
        assert [h["voided"] for h in history] == [i % 3 == 0 for i in range(n)]
        assert history[-1]["normal_ranges"]["gait_speed_m_s"][0] < 1.0 < history[-1]["normal_ranges"]["gait_speed_m_s"][1]
    assert counts[3] == counts[30], counts  # (before: 3 to 4 more per trial, its result, steps and summary)


def test_a_clinic_table_changed_while_serving_is_read_again(server, tmp_path, monkeypatch):
    _, client, _, settings = server
    path = tmp_path / "clinic-norms.csv"
    head = "# Source: the clinic\nparameter,sex,age_min,age_max,mean,sd,unit,source\n"
    path.write_text(head + "gait_speed_m_s,male,60,89,1.00,0.10,m/s,clinic\n")
    monkeypatch.setenv("GAITCAP_NORMS_CSV", str(path))
    tid = client.post("/trials", json={"subject_id": "P5", "session": "v1"}).json()["id"]
    client.post(f"/trials/{tid}/stop")
    client.put("/patients/P5", json={"sex": "male", "birth_year": 1950})
    band = client.get("/patients/P5").json()["history"][0]["normal_ranges"]["gait_speed_m_s"]
    assert band == pytest.approx([1.00 - 0.196, 1.00 + 0.196])
    path.write_text(head + "gait_speed_m_s,male,60,89,1.00,-1,m/s,clinic\n")
    r = client.get("/patients/P5")
    assert r.status_code == 500 and r.json()["detail"] == (
        f"the normative table (GAITCAP_NORMS_CSV): {path} line 3, column sd: gait_speed_m_s needs sd > 0")
    path.write_text(head + "gait_speed_m_s,male,60,89,1.10,0.10,m/s,clinic\n")
    band = client.get("/patients/P5").json()["history"][0]["normal_ranges"]["gait_speed_m_s"]
    assert band == pytest.approx([1.10 - 0.196, 1.10 + 0.196])
