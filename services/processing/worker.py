"""The worker: takes jobs from the catalog's job table under a lease. A ``process`` job runs the one
processing path (:func:`gaitcap.services.processing.trial.process_trial`) on the trial's MCAP where the
catalog records it, with the catalog as its sink: PRELIMINARY gait metrics (robust triangulation) are
stored first, then the REFINED ones (implicit fit), each stage's files listed as they are written, progress
on the trial's record and the bus. A ``calibrate`` job: computes the calibration of a stopped board
recording (:mod:`gaitcap.services.processing.calibration_job`).

Several workers may run; each renews its lease while it works. A worker that dies stops renewing and
its job is taken over by another once the lease has expired (the trial stays ``processing``). The
process stays warm: JAX code is compiled once at start (:meth:`Worker.warm_up`).

Progress goes to the trial's record in the catalog (``stage``, ``progress`` 0..1), where the API reads it.
"""

from __future__ import annotations

import logging
import os
import socket
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

from gaitcap.reconstruction.result import Reconstruction
from gaitcap.services import catalog as cat
from gaitcap.services.catalog.method_keys import params_key
from gaitcap.services.kinematics.shown import patient_age
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.processing.calibration_job import fail_calibration, run_calibration
from gaitcap.services.processing.checks import CheckContext
from gaitcap.services.processing.compiled_code import CompiledCode, CompiledCodeLimit
from gaitcap.services.processing.completion import CompletionSettings
from gaitcap.services.processing.outputs import steps_of, summary_of
from gaitcap.services.processing.pipeline import enable_compile_cache, ring_rig, warm_up
from gaitcap.services.processing.quality import DataQuality, QualityCriteria
from gaitcap.services.processing.room_fetch import RoomFetch, find_recording
from gaitcap.services.processing.trial import (
    StageOutcome,
    TrialInput,
    TrialOptions,
    default_stages,
    process_trial,
    recording_input,
)
from gaitcap.services.processing.viewers.rerun_trial import RerunSettings
from sqlalchemy.exc import OperationalError

log = logging.getLogger(__name__)


class LeaseLost(RuntimeError):
    """Another worker has taken this job over (our lease expired)."""


@dataclass(frozen=True)
class WorkerConfig:
    """catalog_url: SQLite path or URL; data_dir: trial files; lease_s: job lease (s), renewed every
    lease_s / 3; poll_s: how often the job table is polled (s); refine: run the implicit fit;
    rerun: the .rrd's settings (images per second and camera copied from the recording); completion:
    detect the recorded frames the live detector missed before the refined stage (None: the live
    keypoints only); compiled: how many jobs' compiled JAX code the worker keeps before dropping it
    (:mod:`~gaitcap.services.processing.compiled_code`: what bounds its memory); max_rss_mb: a safety net
    only: after a job, a worker whose resident memory (MB) is still above this stops (:meth:`Worker.run`
    returns ``"recycle"``) to be started afresh by its supervisor."""

    catalog_url: str
    data_dir: Path
    worker_id: str = f"{socket.gethostname()}-{os.getpid()}"
    lease_s: float = 10.0
    poll_s: float = 0.2
    refine: bool = True
    fallback_calibration: Path | None = None
    criteria: QualityCriteria = QualityCriteria()
    rerun: RerunSettings = RerunSettings()
    completion: CompletionSettings | None = None
    compiled: CompiledCodeLimit = CompiledCodeLimit()
    max_rss_mb: float = 3000.0
    store: Path | None = None  # this host's mount of the rooms' shared store (gaitcap.services.processing.store)
    fetch: RoomFetch | None = None  # without the store: each room's bus to fetch recordings from (room_fetch)

    def __post_init__(self) -> None:
        if self.max_rss_mb <= 0:
            raise ValueError(f"max_rss_mb: must be > 0 MB, got {self.max_rss_mb}")
        if self.lease_s < 1.0:
            raise ValueError(f"lease_s: must be >= 1 s, got {self.lease_s}")
        if self.poll_s <= 0:
            raise ValueError(f"poll_s: must be > 0, got {self.poll_s}")


CATALOG_RETRY_S = 2.0  # a worker whose catalog is unreachable asks again this often


class LeaseKeeper:
    """Renews a job's lease in a background thread; ``lost`` is set when renewal fails."""

    def __init__(self, db: cat.Catalog, job: cat.JobInfo, worker_id: str, lease_s: float) -> None:
        self.db, self.job, self.worker_id, self.lease_s = db, job, worker_id, lease_s
        self.lost, self._stop = threading.Event(), threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"lease-{job.id}", daemon=True)

    def __enter__(self) -> LeaseKeeper:
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join(5)

    def _run(self) -> None:
        while not self._stop.wait(self.lease_s / 3):
            try:
                if not cat.renew_lease(self.db, self.job.id, self.worker_id, lease_s=self.lease_s):
                    self.lost.set()
                    return
            except Exception:  # a transient DB error: try again next period
                log.exception("lease renewal of job %s failed", self.job.id)

    def check(self) -> None:
        if self.lost.is_set():
            raise LeaseLost(f"job {self.job.id} of {self.job.subject} was taken over")


@dataclass(frozen=True)
class JobKind:
    """What a worker does with a job of one kind: ``run(job, lease)`` does the work; ``fail(job, exc)``
    marks the job's subject failed with the reason."""

    run: Callable[[cat.JobInfo, LeaseKeeper], None]
    fail: Callable[[cat.JobInfo, Exception], None]


def with_calibration_version(db: cat.Catalog, trial_id: str, data: TrialInput) -> TrialInput:
    """The trial's input under the calibration version it was assigned (a calibration refined from people,
    :mod:`gaitcap.services.catalog.calibration_versions`); else as recorded, with its recording's own."""
    from gaitcap.reconstruction.calibration_io import rig_from_toml_text
    from gaitcap.services.catalog.calibration_versions import trial_version_toml

    toml = trial_version_toml(db, trial_id)
    if toml is None:
        return data
    rig = rig_from_toml_text(toml, source=f"trial {trial_id}'s calibration version")
    return replace(data, rig=rig, keypoints=replace(data.keypoints, rig=rig))


def rig_baseline(db: cat.Catalog, data_dir: Path, trial: cat.TrialInfo) -> CheckContext:
    """The rig check's baseline for ``trial``: the patient's keypoints kept by the first trial under its
    calibration whose check found no camera moved and whose keypoints file is readable
    (:func:`~gaitcap.services.catalog.rig_checks.baseline_trial_ids`; a candidate without one, e.g. processed
    before trials kept it, is passed over, logged); none when there is no such trial."""
    from gaitcap.acquisition.readers import load_detections_npz
    from gaitcap.services.catalog.rig_checks import baseline_trial_ids

    for found in baseline_trial_ids(db, trial.calibration_id, excluding=trial.id):
        try:
            return CheckContext(rig_baseline=load_detections_npz(trial_files(data_dir, found).rig_keypoints_npz),
                                baseline_trial=found)
        except (OSError, ValueError) as exc:
            log.warning("trial %s: baseline candidate %s has no usable rig keypoints (%s); trying the next",
                        trial.id, found, exc)
    return CheckContext()


def recording_of(trial: cat.TrialInfo) -> Path:
    """The trial's MCAP where the catalog records it; ValueError naming the trial and the path otherwise."""
    if not trial.recording_path:
        raise ValueError(f"trial {trial.id}: the catalog records no recording path")
    path = Path(trial.recording_path)
    if not path.is_file():
        raise ValueError(f"trial {trial.id}: its recording {path} does not exist")
    return path


class Worker:
    def __init__(self, config: WorkerConfig, *, db: cat.Catalog | None = None) -> None:
        self.config = config
        self.db = db or cat.open_catalog(config.catalog_url)
        self.busy = False  # a job is being processed
        self.compiled = CompiledCode(config.compiled)  # the JAX code compiled for recent trials' shapes
        self.kinds = {  # job kind -> what this worker does with it
            "process": JobKind(run=lambda job, lease: self.process(job.trial_id, lease),
                               fail=lambda job, exc: self._fail_trial(job.trial_id, exc)),
            "calibrate": JobKind(run=lambda job, lease: run_calibration(self.db, job.calibration_id, check=lease.check),
                                 fail=lambda job, exc: fail_calibration(self.db, job.calibration_id, exc)),
        }

    # ------------------------------------------------------------------ loop
    def run(self, stop: threading.Event) -> str:
        """Process jobs until ``stop`` is set (returns ``"stopped"``) or, between jobs, until the process has
        grown past ``max_rss_mb`` (returns ``"recycle"``: start a fresh one)."""
        log.info("worker %s polling %s", self.config.worker_id, self.db.shown_url)
        down_since = None  # the catalog unreachable since (monotonic s): waited out, logged once per outage
        while not stop.is_set():
            try:
                took = self.run_once()
            except OperationalError as exc:  # a job cut by it stays leased: its lease runs out, it is taken again
                if down_since is None:
                    log.warning("worker %s: the catalog is unreachable (%s); trying every %.0f s",
                                self.config.worker_id, str(exc.orig or exc).strip().splitlines()[0][:200],
                                CATALOG_RETRY_S)
                    down_since = time.monotonic()
                stop.wait(CATALOG_RETRY_S)
                continue
            if down_since is not None:
                log.info("worker %s: the catalog answers again (after %.0f s)", self.config.worker_id,
                         time.monotonic() - down_since)
                down_since = None
            if not took:
                stop.wait(self.config.poll_s)
            elif (rss := resident_mb()) > self.config.max_rss_mb:
                log.warning("worker %s: %.0f MB resident after a job, above %.0f MB: stopping to be started afresh",
                            self.config.worker_id, rss, self.config.max_rss_mb)
                return "recycle"
        return "stopped"

    def run_once(self) -> bool:
        """Take and process one job; False when there was none."""
        job = cat.lease_job(self.db, self.config.worker_id, lease_s=self.config.lease_s, kinds=tuple(self.kinds))
        if job is None:
            return False
        log.info("job %s: %s %s (attempt %s)", job.id, job.kind, job.subject, job.attempts)
        self.busy = True
        try:
            return self._run_job(job)
        finally:
            self.busy = False
            self.compiled.after_job()

    def _run_job(self, job: cat.JobInfo) -> bool:
        with LeaseKeeper(self.db, job, self.config.worker_id, self.config.lease_s) as lease:
            try:
                self.kinds[job.kind].run(job, lease)
            except LeaseLost as exc:
                log.warning("%s; leaving it to the other worker", exc)
                return True
            except Exception as exc:  # any failure ends the job's subject as failed, with the reason
                log.exception("%s failed", job.subject)
                if not lease.lost.is_set() and cat.fail_job(self.db, job.id, self.config.worker_id, str(exc)):
                    self.kinds[job.kind].fail(job, exc)
                return True
            if not cat.complete_job(self.db, job.id, self.config.worker_id):
                log.warning("job %s: lease lost before completion", job.id)
        return True

    def _fail_trial(self, trial_id: str, exc: Exception) -> None:
        message = f"{type(exc).__name__}: {exc}" if not isinstance(exc, ValueError) else str(exc)
        try:
            cat.set_state(self.db, trial_id, "failed", error=message[:2000], stage="")
        except cat.IllegalTransition:
            log.warning("trial %s could not be marked failed", trial_id)
        self._report(trial_id, "failed", 1.0)

    # ------------------------------------------------------------------ one trial
    def _report(self, trial_id: str, stage: str, progress: float) -> None:
        """The trial's step (words) and how far it is (0..1), on its record in the catalog."""
        cat.set_progress(self.db, trial_id, stage=stage, progress=progress)

    def process(self, trial_id: str, lease: LeaseKeeper) -> None:
        """The trial's job: the one processing path (:func:`~gaitcap.services.processing.trial.process_trial`)
        on its recording, results into the catalog as each stage is stored."""
        trial = cat.get_trial(self.db, trial_id)
        if trial.state in cat.PROCESSABLE:
            cat.set_state(self.db, trial_id, "processing", expect=trial.state, stage="starting", progress=0.0)
        elif trial.state != "processing":  # done or failed meanwhile: nothing to do
            log.info("trial %s is %s; skipping", trial_id, trial.state)
            return
        recording = find_recording(trial, cat.get_quality(self.db, trial_id).get("recorder", {}),
                                   store=self.config.store, fetch=self.config.fetch, data_dir=self.config.data_dir)
        files = trial_files(self.config.data_dir, trial_id, recording)
        self._report(trial_id, "reading the recording", 0.05)
        t0 = time.perf_counter()
        recorded = recording_input(files.recording, fallback_calibration=self.config.fallback_calibration,
                                   completion=self.config.completion)
        data = with_calibration_version(self.db, trial_id, recorded)
        options = replace(self.options(age_years=patient_age(self.db, trial_id)),
                          check_context=rig_baseline(self.db, self.config.data_dir, trial))
        inputs = {} if data is recorded else {"calibration": str(trial.calibration_id)}
        sink = CatalogSink(self, trial_id, lease, load_s=time.perf_counter() - t0, options=options, inputs=inputs)
        result = process_trial(data, options, files=files, sink=sink)
        self._finish(trial_id, result.quality)

    def options(self, *, age_years: int | None) -> TrialOptions:
        """The clinic's options: both stages (or the preliminary only), kinematics, viewer files of the last."""
        return TrialOptions(stages=default_stages(refine=self.config.refine), age_years=age_years,
                            criteria=self.config.criteria, rerun=self.config.rerun,
                            completion=self.config.completion if self.config.refine else None)

    def _finish(self, trial_id: str, quality: DataQuality) -> None:
        """``done``, or ``done_with_warnings`` when the data had serious problems (this worker's measures,
        a crash recovery or a Start that overrode the rig check)."""
        earlier = {k: v for k, v in cat.get_quality(self.db, trial_id).items() if k != "processing"}
        final = "done_with_warnings" if quality.serious or cat.warnings_of(earlier) else "done"
        cat.set_state(self.db, trial_id, final, expect="processing", stage="done", progress=1.0)
        self._report(trial_id, "done", 1.0)


class CatalogSink:
    """The clinic's sink: each stage's result row, quality and files into the catalog, progress on the
    trial's record, the job's lease checked between steps. Each row is keyed by its stage's method and the
    parameters key of its config (the key research reads it under); ``inputs``: what the trial was processed
    from besides its recording (a calibration version), folded into the key."""

    def __init__(self, worker: Worker, trial_id: str, lease: LeaseKeeper, *, load_s: float, options: TrialOptions,
                 inputs: dict[str, str]) -> None:
        self.worker, self.trial_id, self.lease, self.load_s = worker, trial_id, lease, load_s
        self.plans, self.inputs = {plan.name: plan for plan in options.stages}, inputs
        self.gait_warnings, self.stage = [], ""  # the last stored stage's

    def progress(self, step: str, fraction: float, result: str | None) -> None:
        self.worker._report(self.trial_id, step, fraction)

    def check(self) -> None:
        self.lease.check()

    def stored(self, outcome: StageOutcome, quality: DataQuality) -> None:
        db, report, traj = self.worker.db, outcome.report, outcome.trajectory
        gait_warnings = list(report.warnings) if report else []
        self.gait_warnings, self.stage = gait_warnings, outcome.name
        self.checked(quality)
        extra = {"warnings": gait_warnings, "problem": outcome.problem, "data_quality": quality.to_dict(),
                 "consistency": outcome.consistency,
                 "load_s": round(self.load_s, 3), "compute_s": round(traj.elapsed_s, 3),
                 "gait_s": round(outcome.gait_s, 3)}
        config = self.plans[outcome.name].method
        completed = {"keypoints": "completed after Stop"} if "completion" in quality.checks else {}
        cat.store_result(db, trial_id=self.trial_id, stage=outcome.name, method=traj.method,
                         steps=steps_of(report) if report else [], summary=summary_of(report) if report else {},
                         report=extra, quality=traj.metrics or {}, artifacts=outcome.files,
                         elapsed_s=traj.elapsed_s + outcome.gait_s, method_name=config.name,
                         params_key=params_key(config, inputs={**self.inputs, **completed} or None))
        log.info("trial %s: %s results stored (%s)", self.trial_id, outcome.name, extra)

    def files_added(self, stage: str, files: dict[str, str]) -> None:
        cat.add_artifacts(self.worker.db, self.trial_id, stage, files)

    def checked(self, quality: DataQuality) -> None:
        """The trial's quality as it now stands, with the last stored stage's gait warnings."""
        cat.set_quality(self.worker.db, self.trial_id, "processing",
                        {**quality.to_dict(), "gait_warnings": self.gait_warnings, "stage": self.stage})


def resident_mb() -> float:
    """This process's resident memory now (MB), from /proc/self/statm (0 where there is none)."""
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[1])
    except (OSError, IndexError, ValueError):
        return 0.0
    return pages * os.sysconf("SC_PAGE_SIZE") / 1e6


def warm_worker(*, cameras: int = 10, skeleton: str = "halpe26", cache_dir: Path | None = None) -> float:
    """Compile the preliminary stage for ``cameras`` cameras, load the plotting code and start the .rrd
    writers' and kinematics' server (``apart``); seconds spent."""
    import gaitcap.reconstruction.gait  # noqa: F401
    import rerun  # noqa: F401  (first import is slow)
    from gaitcap.reconstruction.skeletons import get_skeleton
    from gaitcap.services.processing.apart import start_apart_server
    from gaitcap.services.processing.outputs import report_png

    t0 = time.perf_counter()
    start_apart_server()  # its own process: starts while this one compiles
    if cache_dir is not None:
        enable_compile_cache(cache_dir)
    warm_up(ring_rig(cameras), get_skeleton(skeleton))
    import numpy as np

    traj = Reconstruction("warm-up", np.zeros((3, 1, 3)), np.arange(3.0), ("left_heel",))
    report_png(traj, None, title="warm-up")
    return time.perf_counter() - t0
