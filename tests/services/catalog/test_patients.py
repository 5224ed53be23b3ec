"""Patients and a trial's void mark in a real SQLite and PostgreSQL catalog: typed refusals, the age at a trial."""

import calendar

import pytest
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import patients as pat


@pytest.fixture
def db(catalog_url):
    c = cat.open_catalog(catalog_url)
    yield c
    c.close()


def _trial(db, subject="P001"):
    t = cat.start_trial(db, subject_id=subject, session="visit1", recording_path_for=lambda t: f"/d/{t}.mcap")
    return cat.set_state(db, t.id, "recorded")


def test_void_refusals_are_typed_not_worded(db):
    tid = _trial(db).id
    with pytest.raises(pat.VoidReasonMissing, match="reason"):
        pat.void_trial(db, tid, by="alice", reason=" no ")
    assert pat.void_trial(db, tid, by="alice", reason="wrong shoes").voided
    with pytest.raises(pat.TrialAlreadyVoid, match=f"trial {tid} is already void \\(wrong shoes\\)"):
        pat.void_trial(db, tid, by="bob", reason="another reason")
    assert pat.get_details(db, tid).voided_by == "alice"  # the first mark stays
    with pytest.raises(cat.TrialNotFound):
        pat.void_trial(db, "T-NOPE", by="alice", reason="wrong shoes")


def test_age_at_a_trial_is_by_calendar_year_of_its_start(db):
    from dataclasses import replace

    trial = _trial(db, "P002")
    p = pat.update_patient(db, "P002", sex="female", birth_year=1956)[0]
    new_year_2026 = calendar.timegm((2026, 1, 1, 0, 0, 1, 0, 0, 0))
    assert pat.age_at_trial(p, replace(trial, started_at=new_year_2026, created_at=0.0)) == 70
    assert pat.age_at_trial(p, replace(trial, started_at=new_year_2026 - 2)) == 69  # 31 Dec 2025, UTC
    assert pat.age_at_trial(p, replace(trial, started_at=None, created_at=new_year_2026)) == 70  # never started
    assert pat.age_at_trial(replace(p, birth_year=None), trial) is None
