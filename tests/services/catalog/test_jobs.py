"""Job leases on a real SQLite file and a PostgreSQL database: exclusive takes, renewal, take-over after expiry, give-up."""

import time

import pytest
from gaitcap.services import catalog as cat


@pytest.fixture
def db(catalog_url):
    c = cat.open_catalog(catalog_url)
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


def test_a_calibration_job_is_taken_only_by_workers_of_its_kind_and_fails_its_calibration_on_give_up(db):
    from gaitcap.services.catalog import calibrations as cals

    c, _ = db
    board = cals.start_board_recording(c, recording_path_for=lambda i: f"/d/{i}.mcap")
    cals.queue_calibration(c, board.id, frames=60)
    assert cat.lease_job(c, "trials-only", kinds=("process",)) is None
    for worker in ("w1", "w2", "w3"):  # three takes, each lease lost (the worker died)
        job = cat.lease_job(c, worker, lease_s=0.05, kinds=("calibrate",))
        assert (job.kind, job.calibration_id, job.trial_id, job.worker_id) == ("calibrate", board.id, None, worker)
        time.sleep(0.1)
    assert cat.lease_job(c, "w4", kinds=("calibrate",)) is None
    assert cat.jobs_for_calibration(c, board.id)[0].state == "failed"
    gave_up = cals.get_calibration(c, board.id)
    assert gave_up.state == "failed" and "stopped 3 times (worker lost); gave up" in gave_up.error



def test_a_job_names_its_kind_and_subject():
    from gaitcap.services.catalog.jobs import new_job

    with pytest.raises(ValueError, match="job kind"):
        new_job("reprocess", trial_id="T1")
    with pytest.raises(ValueError, match="calibration_id"):
        new_job("calibrate", trial_id="T1")


def test_workers_taking_jobs_at_once_take_each_job_exactly_once(catalog_url):
    """Four workers, each on its own connection, take 24 queued jobs as fast as they can: every job is taken,
    none twice (PostgreSQL: FOR UPDATE SKIP LOCKED; SQLite: one writer at a time)."""
    import threading

    c = cat.open_catalog(catalog_url)
    queued = set()
    for i in range(24):
        t = cat.start_trial(c, subject_id=f"P{i}", session="s1")
        cat.set_state(c, t.id, "recorded")
        queued.add(cat.enqueue_job(c, t.id).id)
    taken, barrier = [], threading.Barrier(4)

    def work(name):
        mine = cat.open_catalog(catalog_url)
        barrier.wait()
        try:
            while (job := cat.lease_job(mine, name, lease_s=60)) is not None:
                taken.append(job.id)
                assert cat.complete_job(mine, job.id, name)
        finally:
            mine.close()

    threads = [threading.Thread(target=work, args=(f"w{i}",)) for i in range(4)]
    for th in threads:
        th.start()
    for th in threads:
        th.join(60)
    assert sorted(taken) == sorted(queued)
    c.close()
