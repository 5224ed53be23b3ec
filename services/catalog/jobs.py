"""The job table with leases.

A worker takes a job with :func:`lease_job` (atomic conditional UPDATE, so two workers never hold the
same job; on PostgreSQL the candidates are read ``FOR UPDATE SKIP LOCKED``, so workers on several hosts each
take a different job at once instead of queueing behind one row; SQLite's write transaction already admits
one taker at a time), renews the lease while it works (:func:`renew_lease`) and ends it with :func:`complete_job`
or :func:`fail_job`. A worker that dies stops renewing; when ``lease_expires_at`` has passed the job
is leased again by another worker (``attempts`` counts the takes; after ``max_attempts`` it fails, and so
does its subject). Kinds (:data:`SUBJECTS`): ``process`` a trial, ``calibrate`` a board recording.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from gaitcap.services.catalog.db import Catalog
from gaitcap.services.catalog.models import Calibration, Job, Trial
from gaitcap.services.catalog.states import PROCESSABLE, TrialState
from sqlalchemy import or_, select, update

QUEUED, RUNNING, DONE, FAILED = "queued", "running", "done", "failed"


SUBJECTS = {"process": "trial_id", "calibrate": "calibration_id"}  # job kind -> the column naming its subject


@dataclass(frozen=True)
class JobInfo:
    id: int
    trial_id: str | None
    kind: str
    state: str
    attempts: int
    worker_id: str
    lease_expires_at: float
    error: str
    calibration_id: str | None = None

    @property
    def subject(self) -> str:
        """What the job works on, in words (``trial T...`` or ``calibration C...``)."""
        return f"trial {self.trial_id}" if self.kind == "process" else f"calibration {self.calibration_id}"


def _info(job: Job) -> JobInfo:
    return JobInfo(job.id, job.trial_id, job.kind, job.state, job.attempts, job.worker_id,
                   job.lease_expires_at, job.error, job.calibration_id)


def new_job(kind: str, *, max_attempts: int = 3, **subject: str) -> Job:
    """A queued job row of ``kind`` on its subject (``trial_id=`` or ``calibration_id=``), to add in a session."""
    column = SUBJECTS.get(kind)
    if column is None:
        raise ValueError(f"job kind: must be one of {sorted(SUBJECTS)}, got {kind!r}")
    if set(subject) != {column} or not subject[column]:
        raise ValueError(f"a {kind!r} job needs {column}= and nothing else, got {sorted(subject)}")
    return Job(kind=kind, state=QUEUED, attempts=0, max_attempts=max_attempts, worker_id="",
               lease_expires_at=0.0, created_at=time.time(), error="", **subject)


def enqueue_job(catalog: Catalog, trial_id: str, *, max_attempts: int = 3) -> JobInfo:
    """Queue processing of trial ``trial_id``."""
    with catalog.session() as s:
        job = new_job("process", max_attempts=max_attempts, trial_id=trial_id)
        s.add(job)
        s.flush()
        return _info(job)


def _takeable(now: float):
    return or_(Job.state == QUEUED, (Job.state == RUNNING) & (Job.lease_expires_at < now))


def lease_job(catalog: Catalog, worker_id: str, *, lease_s: float = 10.0,
              kinds: tuple[str, ...] = ("process",)) -> JobInfo | None:
    """Take the oldest queued job of ``kinds`` (or one whose lease expired). None when there is nothing to do.

    A job whose lease expired after ``max_attempts`` takes is marked failed instead, and so is its subject.
    """
    if lease_s <= 0:
        raise ValueError(f"lease_s: must be > 0, got {lease_s}")
    now = time.time()
    with catalog.session() as s:
        candidates = (select(Job).where(Job.kind.in_(kinds), _takeable(now)).order_by(Job.id).limit(5)
                      .with_for_update(skip_locked=True))
        for job in s.scalars(candidates):
            if job.attempts >= job.max_attempts:
                job.state, job.finished_at = FAILED, now
                job.error = (job.error or "") + f" gave up after {job.attempts} attempts"
                _GIVE_UP[job.kind](s, job, f"stopped {job.attempts} times (worker lost); gave up")
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


def _fail_trial(s, job: Job, error: str) -> None:
    states = [st.value for st in (*PROCESSABLE, TrialState.PROCESSING)]
    s.execute(update(Trial).where(Trial.id == job.trial_id, Trial.state.in_(states))
              .values(state=TrialState.FAILED.value, error=f"processing {error}", updated_at=time.time(), stage="")
              .execution_options(synchronize_session=False))


def _fail_calibration(s, job: Job, error: str) -> None:
    s.execute(update(Calibration).where(Calibration.id == job.calibration_id, Calibration.state == "calibrating")
              .values(state="failed", error=f"the calibration job {error}; press Calibrate to record again",
                      stage="", progress=1.0)
              .execution_options(synchronize_session=False))


_GIVE_UP = {"process": _fail_trial, "calibrate": _fail_calibration}  # job kind -> fail its subject


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
    with catalog.reading() as s:
        return [_info(j) for j in s.scalars(select(Job).where(Job.trial_id == trial_id).order_by(Job.id))]


def jobs_for_calibration(catalog: Catalog, cal_id: str) -> list[JobInfo]:
    with catalog.reading() as s:
        return [_info(j) for j in s.scalars(select(Job).where(Job.calibration_id == cal_id).order_by(Job.id))]
