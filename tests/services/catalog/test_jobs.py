"""Job leases on a real SQLite file: exclusive takes, renewal, take-over after expiry, give-up."""

import time

import pytest
from gaitcap.services import catalog as cat


@pytest.fixture
def db(tmp_path):
    c = cat.open_catalog(tmp_path / "catalog.sqlite")
    t = cat.start_trial(c, subject_id="P1", session="s1")
    cat.set_state(c, t.id, "recorded")
    yield c, t.id
    c.close()


def test_a_job_is_leased_once(db):
    c, tid = db
    cat.enqueue_job(c, tid)
    a = cat.lease_job(c, "w1", lease_s=30)
    assert a is not None and a.trial_id == tid and a.attempts == 1 and a.worker_id == "w1"
    assert cat.lease_job(c, "w2", lease_s=30) is None
    assert cat.renew_lease(c, a.id, "w1", lease_s=30)
    assert not cat.renew_lease(c, a.id, "w2")
    assert cat.complete_job(c, a.id, "w1")
    assert cat.lease_job(c, "w2") is None
    assert cat.jobs_for_trial(c, tid)[0].state == "done"


def test_expired_lease_is_taken_over_and_old_holder_loses_it(db):
    c, tid = db
    cat.enqueue_job(c, tid)
    a = cat.lease_job(c, "w1", lease_s=0.2)
    time.sleep(0.3)
    b = cat.lease_job(c, "w2", lease_s=30)
    assert b is not None and b.id == a.id and b.attempts == 2 and b.worker_id == "w2"
    assert not cat.renew_lease(c, a.id, "w1") and not cat.complete_job(c, a.id, "w1")
    assert cat.complete_job(c, b.id, "w2")


def test_job_gives_up_after_max_attempts(db):
    c, tid = db
    cat.enqueue_job(c, tid, max_attempts=1)
    cat.lease_job(c, "w1", lease_s=0.1)
    time.sleep(0.2)
    assert cat.lease_job(c, "w2") is None
    job = cat.jobs_for_trial(c, tid)[0]
    assert job.state == "failed" and "gave up" in job.error
    assert cat.get_trial(c, tid).state == "failed" and "gave up" in cat.get_trial(c, tid).error


def test_fail_job_stores_the_error(db):
    c, tid = db
    cat.enqueue_job(c, tid)
    a = cat.lease_job(c, "w1")
    assert cat.fail_job(c, a.id, "w1", "calibration: camera cam3 missing")
    assert cat.jobs_for_trial(c, tid)[0].error == "calibration: camera cam3 missing"
    with pytest.raises(ValueError, match="lease_s"):
        cat.lease_job(c, "w1", lease_s=0)
