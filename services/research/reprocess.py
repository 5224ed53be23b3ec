"""Batch reprocessing: re-run reconstruction + gait analysis of recorded trials under given methods.

A plan (:func:`plan_reprocess`) pairs every selected trial with every :class:`MethodSpec`, leaving out
pairs research already stored in the catalog (``gaitcap.services.catalog.method_results``); :func:`run_plan` hands the tasks to an
executor (``gaitcap.services.research.executors``: inline, local process pool, Ray) and counts what came back. Each task
(:func:`run_task`, run in a worker process) checks the store again, computes, writes its files (temp +
rename) and inserts its row idempotently. Nothing is held in memory between tasks, so a run that
crashed or was killed simply resumes when started again: done pairs are skipped.

What a task computes for trial T and method M:
- the 3D trajectory (``gaitcap.reconstruction.methods.reconstruct``) and the paper's metrics (GC_5/10/20,
  L_reproj, L_skeleton, L_smooth; MPJPE and heel/toe errors when the trial has ground truth);
- gait analysis (``gaitcap.reconstruction.gait.analyze_gait``): the catalog's summary and the step count;
- residuals against a reference, per footfall (heel/toe forward and lateral, step and stride length,
  step width, mm) with the walkway alignment of ``gaitcap.reconstruction.gait``: the reference is the trial's
  ``walkway.csv`` when there is one, else the footfalls of ``ground_truth.npz`` (synthetic trials:
  the world's exact heel and toe points and contact times).

Files of a trial (the folder of its recording): ``recording.mcap``, optional ``walkway.csv`` and
``ground_truth.npz``; outputs under ``reprocess/<method>-<params_key>/`` (``trajectory.npz``,
``result.json``).
"""

from __future__ import annotations

import fnmatch
import json
import logging
import os
import socket
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from gaitcap.acquisition.fileio import atomic_write_bytes
from gaitcap.reconstruction.jsonable import finite_or_none, json_ready
from gaitcap.services import catalog as cat
from gaitcap.services.catalog.method_results import (
    MethodResult,
    delete_failed,
    done_keys,
    is_done,
    put_result,
)
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.research.method_specs import MethodSpec, canonical

log = logging.getLogger(__name__)

REPROCESS_DIR = "reprocess"
WALKWAY_FILE = "walkway.csv"
GROUND_TRUTH_FILE = "ground_truth.npz"
SELECTABLE_STATES = ("recorded", "recovered", "processing", "done", "done_with_warnings", "failed")
_CATALOGS: dict[str, cat.Catalog] = {}
_CACHES: set[str] = set()


# ---------------------------------------------------------------------------------------------- selection
@dataclass(frozen=True)
class TrialSelection:
    """Which trials: ``patterns`` (shell patterns matched against the trial id, the subject id and
    ``subject/session``; empty = all) among trials in ``states``."""

    patterns: tuple[str, ...] = ()
    states: tuple[str, ...] = SELECTABLE_STATES

    @classmethod
    def parse(cls, text: str | None) -> TrialSelection:
        """``"P001/*,2026*"`` -> patterns; empty, None or ``all`` -> every trial."""
        items = tuple(p.strip() for p in (text or "").split(",") if p.strip())
        return cls(() if items in ((), ("all",)) else items)

    def matches(self, trial: cat.TrialInfo) -> bool:
        if trial.state not in self.states:
            return False
        names = (trial.id, trial.subject_id, f"{trial.subject_id}/{trial.session}")
        return not self.patterns or any(fnmatch.fnmatchcase(n, p) for p in self.patterns for n in names)


@dataclass(frozen=True)
class TrialRef:
    """A trial to reprocess: its recording (MCAP) and its folder (reference files, outputs)."""

    trial_id: str
    recording: Path

    @property
    def folder(self) -> Path:
        return self.recording.parent


def select_trials(db: cat.Catalog, data_dir: Path, selection: TrialSelection) -> tuple[list[TrialRef], list[str]]:
    """(trials with a recording, ids of matching trials whose recording file is missing), by id."""
    found, missing = [], []
    for trial in sorted(cat.list_trials(db, limit=10_000_000), key=lambda t: t.id):
        if not selection.matches(trial):
            continue
        path = trial_files(data_dir, trial.id, trial.recording_path).recording
        if not path.is_file():  # a data folder moved since: the trial's default place in it
            path = trial_files(data_dir, trial.id).recording
        (found.append(TrialRef(trial.id, path.resolve())) if path.is_file() else missing.append(trial.id))
    return found, missing


# ---------------------------------------------------------------------------------------------- plan
@dataclass(frozen=True)
class ReprocessTask:
    """One (trial, method) pair; picklable, self-contained (a worker process needs nothing else)."""

    catalog_url: str
    trial: TrialRef
    spec: MethodSpec
    write_files: bool = True
    compile_cache: str = ""  # JAX persistent compilation cache folder shared by the workers ("" = none)


@dataclass(frozen=True)
class ReprocessPlan:
    tasks: tuple[ReprocessTask, ...]
    trials: tuple[TrialRef, ...]
    specs: tuple[MethodSpec, ...]
    already_done: int
    missing: tuple[str, ...]

    @property
    def total(self) -> int:
        return len(self.trials) * len(self.specs)


def plan_reprocess(db: cat.Catalog, data_dir: Path, selection: TrialSelection, specs: Iterable[MethodSpec], *,
                   retry_failed: bool = False, write_files: bool = True,
                   compile_cache: Path | None = None) -> ReprocessPlan:
    """Every selected trial x every method, minus pairs already stored (failed ones too, unless
    ``retry_failed``: then those are forgotten and computed again). ``compile_cache``: a folder for JAX's
    persistent compilation cache in the worker processes (e.g. ``<data_dir>/.jax-cache``), so a fresh
    worker loads compiled code instead of compiling again; None for in-process runs."""
    unique: dict[tuple[str, str], MethodSpec] = {}
    for spec in specs:  # the same config twice (other spelling or label): the first one
        unique.setdefault((spec.method, spec.key), spec)
    specs = tuple(unique.values())
    if not specs:
        raise ValueError("method: give at least one method")
    trials, missing = select_trials(db, Path(data_dir), selection)
    if not trials and not missing:
        which = ", ".join(selection.patterns) or "all"
        raise ValueError(f"trials: no trial in states {'/'.join(selection.states)} matches {which!r} in {db.shown_url}")
    if retry_failed:
        delete_failed(db, [t.trial_id for t in trials])
    done = done_keys(db)
    cache = str(Path(compile_cache).resolve()) if compile_cache else ""
    tasks = [ReprocessTask(db.url, t, s, write_files, cache) for t in trials for s in specs
             if (t.trial_id, s.method, s.key) not in done]
    return ReprocessPlan(tuple(tasks), tuple(trials), specs, len(trials) * len(specs) - len(tasks), tuple(missing))


# ---------------------------------------------------------------------------------------------- running
@dataclass(frozen=True)
class TaskOutcome:
    """What one task did: ``status`` computed | skipped (already stored) | failed (stored as failed)."""

    trial_id: str
    method: str
    params_key: str
    status: str
    error: str = ""
    elapsed_s: float = 0.0
    worker: str = ""


@dataclass(frozen=True)
class ReprocessSummary:
    computed: int
    skipped: int
    failed: int
    outcomes: tuple[TaskOutcome, ...] = field(default_factory=tuple)


def task_resources(gpus_per_fit: float) -> Callable[[ReprocessTask], object]:
    """Resource request of a task: 1 CPU; ``gpus_per_fit`` GPUs for trajectory fits."""
    from gaitcap.reconstruction.methods import Explicit, Implicit
    from gaitcap.services.research.executors import TaskResources

    fits = {Explicit.name, Implicit.name}

    def resources(task: ReprocessTask) -> TaskResources:
        return TaskResources(1.0, gpus_per_fit if task.spec.method in fits else 0.0)

    return resources


def run_plan(plan: ReprocessPlan, executor, *, on_outcome: Callable[[TaskOutcome], None] | None = None,
             resources=None) -> ReprocessSummary:
    """Run the plan's tasks on ``executor`` (``gaitcap.services.research.executors``), calling ``on_outcome`` as each ends."""
    outcomes = []
    for outcome in executor.map_unordered(run_task, plan.tasks, resources):
        outcomes.append(outcome)
        if on_outcome is not None:
            on_outcome(outcome)
    count = {s: sum(o.status == s for o in outcomes) for s in ("computed", "skipped", "failed")}
    return ReprocessSummary(count["computed"], count["skipped"] + plan.already_done, count["failed"], tuple(outcomes))


def _catalog(url: str) -> cat.Catalog:
    if url not in _CATALOGS:
        _CATALOGS[url] = cat.open_catalog(url)
    return _CATALOGS[url]


def _use_compile_cache(path: str) -> None:
    """Turn on JAX's persistent compilation cache once per process (best effort)."""
    from gaitcap.services.processing.pipeline import enable_compile_cache

    if path and path not in _CACHES:
        _CACHES.add(path)
        try:
            enable_compile_cache(Path(path))
        except OSError as exc:
            log.warning("compilation cache %s unusable: %s", path, exc)


def run_task(task: ReprocessTask) -> TaskOutcome:
    """Compute one (trial, method) result and store it (idempotent; in a worker process)."""
    _use_compile_cache(task.compile_cache)
    db = _catalog(task.catalog_url)
    spec, key, worker = task.spec, task.spec.key, f"{socket.gethostname()}-{os.getpid()}"
    if is_done(db, task.trial.trial_id, spec.method, key):
        return TaskOutcome(task.trial.trial_id, spec.method, key, "skipped", worker=worker)
    t0 = time.perf_counter()
    try:
        result = compute_result(task)
    except Exception as exc:  # the trial's own problem: stored as a failed result with the reason
        log.exception("trial %s, %s failed", task.trial.trial_id, spec.name)
        message = str(exc) if isinstance(exc, ValueError) else f"{type(exc).__name__}: {exc}"
        result = MethodResult(task.trial.trial_id, spec.method, key, spec.to_dict(), "failed", message)
    elapsed = time.perf_counter() - t0
    result = MethodResult(**{**result.__dict__, "elapsed_s": elapsed, "worker": worker, "created_at": time.time()})
    put_result(db, result, config=canonical(spec.config()))
    status = "computed" if result.ok else "failed"
    return TaskOutcome(task.trial.trial_id, spec.method, key, status, result.error, elapsed, worker)


# ---------------------------------------------------------------------------------------------- one result
def compute_result(task: ReprocessTask) -> MethodResult:
    """Reconstruction, metrics, gait and residuals of one trial under one method (raises ValueError): the
    one processing path with the method as its only stage, nothing written in the trial's files."""
    from gaitcap.services.processing.artifacts import TrialFiles
    from gaitcap.services.processing.people import read_choice
    from gaitcap.services.processing.trial import (
        StagePlan,
        TrialOptions,
        ViewerFiles,
        process_trial,
        recording_input,
    )

    data = recording_input(task.trial.recording)  # several people in view: the patient (stored choice)
    recording = data.keypoints.recording
    options = TrialOptions(stages=(StagePlan(task.spec.method, task.spec.config()),), kinematics=False,
                           viewer_files=ViewerFiles.NONE, choice=read_choice(TrialFiles(task.trial.folder)),
                           checks=(),  # the trial's checks are the clinic's, once per trial: not per method

                           truth_mm=_truth_points(task.trial.folder, recording.shape[1], recording.skeleton.name))
    result = process_trial(data, options, files=None)
    stage = result.last
    rec, traj = stage.reconstruction, stage.trajectory  # the worker's trajectory: its sampler and gait analysis
    points, times, names = traj.points_mm, traj.times_s, list(traj.joint_names)
    gait = _gait(stage)
    residuals = _residuals(task.trial, points, times, names, traj.trajectory)
    metrics = {k: v for k, v in rec.metrics.items()}
    metrics.update({f"fit.{k}": float(v) for k, v in rec.losses.items() if np.isscalar(v) and k != "seconds"})
    result = MethodResult(task.trial.trial_id, task.spec.method, task.spec.key, task.spec.to_dict(), "ok",
                          skeleton=result.layout.skeleton if result.layout else recording.skeleton.name,
                          metrics=json_ready(metrics), gait=gait, residuals=residuals)
    if task.write_files:
        result = MethodResult(**{**result.__dict__, "artifacts": _write_files(task, result, traj)})
    return result


def _truth_points(folder: Path, frames: int, skeleton: str) -> np.ndarray | None:
    """Ground-truth points (T, J, 3) mm from ``ground_truth.npz`` when it matches the recording's ``frames``
    and ``skeleton``'s joints."""
    from gaitcap.reconstruction.skeletons import get_skeleton

    path = folder / GROUND_TRUTH_FILE
    if not path.is_file():
        return None
    joints = tuple(get_skeleton(skeleton).joint_names)
    with np.load(path, allow_pickle=False) as z:
        points, names = z["points_mm"], tuple(str(n) for n in z["joint_names"])
    if points.shape != (frames, len(joints), 3) or names != joints:
        log.warning("%s: shape %s / joints do not match the recording; not used", path, points.shape)
        return None
    return points


def _gait(stage) -> dict:
    """The one path's gait analysis of the stage and the catalog's summary."""
    from gaitcap.services.processing.outputs import summary_of

    if stage.report is None:
        return {"problem": stage.problem, "steps": 0, "summary": {}}
    return {"problem": "", "steps": len(stage.report.steps), "summary": summary_of(stage.report)}


def _reference(trial: TrialRef):
    """The walkway footfalls to compare with: ``walkway.csv`` (the trial's rows), else ground truth."""
    from gaitcap.acquisition.readers import read_walkway_csv

    walkway = trial.folder / WALKWAY_FILE
    if walkway.is_file():
        trials = read_walkway_csv(walkway)
        named = [t for t in trials if t.name == trial.trial_id]
        return "walkway", (named or list(trials))[0]
    truth = trial.folder / GROUND_TRUTH_FILE
    if truth.is_file():
        return "ground truth", _truth_footfalls(truth, trial.trial_id)
    return None, None


def _truth_footfalls(path: Path, name: str):
    """The straight-pass footfalls of a ground-truth file as an exact walkway (same frame and clock)."""
    from gaitcap.reconstruction.gait.walkway import WalkwayTrial

    with np.load(path, allow_pickle=False) as z:
        rows = np.flatnonzero((z["step_pass"] >= 0) & np.isfinite(z["step_toe_off_s"]))
        if len(rows) < 2:
            raise ValueError(f"{path}: fewer than 2 straight-pass footfalls in the ground truth")
        return WalkwayTrial(name, tuple(str(f) for f in z["step_foot"][rows]), z["step_heel_strike_s"][rows],
                            z["step_toe_off_s"][rows], z["step_heel_mm"][rows, :2], z["step_toe_mm"][rows, :2])


def _residuals(trial: TrialRef, points, times, names, sample) -> dict:
    """Per-footfall kinematic - reference errors (mm) of the walkway comparison, or the reason none."""
    from gaitcap.reconstruction.gait import compare_with_walkway
    from gaitcap.reconstruction.gait.walkway import RESIDUAL_PARAMETERS

    kind, reference = _reference(trial)
    if reference is None:
        return {}
    try:
        cmp = compare_with_walkway([(points, times, names)], [reference], samples=[sample])
    except ValueError as exc:
        return {"reference": kind, "problem": str(exc)}
    out = {p: [finite_or_none(getattr(c, p)) for c in cmp.contacts] for p in RESIDUAL_PARAMETERS}
    return {"reference": kind, "problem": "", "footfalls": len(cmp.contacts), "parameters": out,
            "forward_bias_mm": finite_or_none(cmp.forward_bias_mm), "offset_s": finite_or_none(next(iter(cmp.offsets_s.values()), None))}


def _write_files(task: ReprocessTask, result: MethodResult, traj) -> dict[str, str]:
    from gaitcap.services.processing.outputs import write_npz

    folder = task.trial.folder / REPROCESS_DIR / f"{task.spec.method}-{task.spec.key}"
    npz = folder / "trajectory.npz"  # the worker's result file
    write_npz(npz, traj)
    summary = folder / "result.json"
    atomic_write_bytes(summary, json.dumps({**result.comparable(), "spec": result.spec}, indent=1,
                                           default=float).encode())
    return {"trajectory_npz": str(npz), "result_json": str(summary)}
