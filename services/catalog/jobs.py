"""The job table with leases.

A worker takes a job with :func:`lease_job` (atomic conditional UPDATE, so two workers never hold the
same job), renews the lease while it works (:func:`renew_lease`) and ends it with :func:`complete_job`
or :func:`fail_job`. A worker that dies stops renewing; when ``lease_expires_at`` has passed the job
is leased again by another worker (``attempts`` counts the takes; after ``max_attempts`` it fails).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from gaitcap.services.catalog.db import Catalog
from gaitcap.services.catalog.models import Job, Trial
from gaitcap.services.catalog.states import PROCESSABLE, TrialState
from sqlalchemy import or_, select, update

QUEUED, RUNNING, DONE, FAILED = "queued", "running", "done", "failed"


@dataclass(frozen=True)
class JobInfo:
    id: int
    trial_id: str
    kind: str
    state: str
    attempts: int
    worker_id: str
    lease_expires_at: float
    error: str


def _info(job: Job) -> JobInfo:
    return JobInfo(job.id, job.trial_id, job.kind, job.state, job.attempts, job.worker_id,
                   job.lease_expires_at, job.error)


def enqueue_job(catalog: Catalog, trial_id: str, *, kind: str = "process", max_attempts: int = 3) -> JobInfo:
    with catalog.session() as s:
        job = Job(trial_id=trial_id, kind=kind, state=QUEUED, attempts=0, max_attempts=max_attempts,
                  worker_id="", lease_expires_at=0.0, created_at=time.time(), error="")
        s.add(job)
        s.flush()
        return _info(job)


def _takeable(now: float):
    return or_(Job.state == QUEUED, (Job.state == RUNNING) & (Job.lease_expires_at < now))


def lease_job(catalog: Catalog, worker_id: str, *, lease_s: float = 10.0, kind: str = "process") -> JobInfo | None:
    """Take the oldest queued job (or one whose lease expired). None when there is nothing to do.

    A job whose lease expired after ``max_attempts`` takes is marked failed instead.
    """
    if lease_s <= 0:
        raise ValueError(f"lease_s: must be > 0, got {lease_s}")
    now = time.time()
    with catalog.session() as s:
        for job in s.scalars(select(Job).where(Job.kind == kind, _takeable(now)).order_by(Job.id).limit(5)):
            if job.attempts >= job.max_attempts:
                job.state, job.finished_at = FAILED, now
                job.error = (job.error or "") + f" gave up after {job.attempts} attempts"
                _fail_trial(s, job.trial_id, f"processing stopped {job.attempts} times (worker lost); gave up")
                continue
            taken = s.execute(
                update(Job).where(Job.id == job.id, _takeable(now))
                .values(state=RUNNING, worker_id=worker_id, lease_expires_at=now + lease_s,
                        attempts=Job.attempts + 1, started_at=now)
                .execution_options(synchronize_session=False)
            ).rowcount
            if taken == 1:
                s.flush()
                s.refresh(job)
                return _info(job)
    return None


def _fail_trial(s, trial_id: str, error: str) -> None:
    states = [st.value for st in (*PROCESSABLE, TrialState.PROCESSING)]
    s.execute(update(Trial).where(Trial.id == trial_id, Trial.state.in_(states))
              .values(state=TrialState.FAILED.value, error=error, updated_at=time.time(), stage="")
              .execution_options(synchronize_session=False))


def renew_lease(catalog: Catalog, job_id: int, worker_id: str, *, lease_s: float = 10.0) -> bool:
    """Extend the lease; False if this worker no longer holds the job (it was taken over)."""
    with catalog.session() as s:
        n = s.execute(
            update(Job).where(Job.id == job_id, Job.worker_id == worker_id, Job.state == RUNNING)
            .values(lease_expires_at=time.time() + lease_s)
        ).rowcount
        return n == 1


def complete_job(catalog: Catalog, job_id: int, worker_id: str) -> bool:
    with catalog.session() as s:
        n = s.execute(
            update(Job).where(Job.id == job_id, Job.worker_id == worker_id, Job.state == RUNNING)
            .values(state=DONE, finished_at=time.time())
        ).rowcount
        return n == 1


def fail_job(catalog: Catalog, job_id: int, worker_id: str, error: str) -> bool:
    """Mark a job failed for good (the error is stored). False if this worker lost the lease."""
    with catalog.session() as s:
        n = s.execute(
            update(Job).where(Job.id == job_id, Job.worker_id == worker_id, Job.state == RUNNING)
            .values(state=FAILED, finished_at=time.time(), error=error[:4000])
        ).rowcount
        return n == 1


def jobs_for_trial(catalog: Catalog, trial_id: str) -> list[JobInfo]:
    with catalog.session() as s:
        return [_info(j) for j in s.scalars(select(Job).where(Job.trial_id == trial_id).order_by(Job.id))]
