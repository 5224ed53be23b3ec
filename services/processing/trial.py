"""One trial, one path: :func:`process_trial` is the only place that sequences a trial's stages.

Every consumer of a trial (the clinic's worker, ``gaitcap process``, ``gaitcap reconstruct``, research
reprocessing and sweeps) is an adapter that chooses the input (:class:`TrialInput`), the options
(:class:`TrialOptions`: which reconstruction stages, which optional steps) and where results go (a
:class:`TrialSink`: the catalog, an output folder, the research store); none of them decides which
steps run or in which order. The sequence:

1. usable input (:func:`~gaitcap.services.processing.pipeline.check_usable`), before anything is written;
2. keypoint layout (:func:`~gaitcap.services.processing.pipeline.resolve_layout`; option ``layout_check``);
3. the patient among the people in view (:func:`~gaitcap.services.processing.pipeline.patient_input`);
4. data quality of the recording (:func:`~gaitcap.services.processing.quality.recording_quality`);
5. each reconstruction stage in order (default: preliminary robust triangulation, refined implicit fit):
   the trajectory (refused when no joint could be reconstructed), the reprojection error of the first
   stage into the quality block, gait (:func:`~gaitcap.services.processing.pipeline.gait_of`) with the
   steps it could not count into the quality block (the ``steps`` check, the last stage's), the stage's
   data files, ``sink.stored``, its views (TRC, plot) and, by ``viewer_files``, its viewer files;
   each stage's consistency rules beside its numbers; with ``completion`` settings, before the last
   stage every recorded frame the live detector missed is detected from the trial's images (the refined
   result then rests on the complete keypoints and says so: its method and the quality block's
   ``completion`` check);
6. once every stage is stored (the results are never held back by them), the trial's checks of its
   results on the first stage's points (one person, the rig: :mod:`.checks`): into the trial's quality
   (``sink.checked``) and ``checks.json`` in its folder;
7. joint kinematics of the last stage (option ``kinematics``; never fails the trial).

A step left out by the options is named in :attr:`TrialResult.skipped` with the option that left it out.
"""

from __future__ import annotations

import contextlib
import enum
import logging
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Protocol

import numpy as np
from gaitcap.acquisition.importers.keypoint_input import KeypointInput
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.result import Reconstruction
from gaitcap.services.processing.artifacts import TrialFiles
from gaitcap.services.processing.checks import (
    CheckContext,
    completion_check,
    one_person_check,
    rig_check,
    stage_consistency,
)
from gaitcap.services.processing.completion import CompletionSettings
from gaitcap.services.processing.pipeline import (
    NoUsableObservations,
    check_usable,
    gait_of,
    patient_input,
    preliminary,
    resolve_layout,
    trajectory_of,
)
from gaitcap.services.processing.quality import (
    DataQuality,
    QualityCriteria,
    recording_quality,
    reprojection_px,
    with_check,
    with_reprojection,
)
from gaitcap.services.processing.recorded_images import RecordedImages
from gaitcap.services.processing.viewers.rerun_trial import RerunSettings

log = logging.getLogger(__name__)


# ---------------------------------------------------------------------------------------------- input
@dataclass(frozen=True, eq=False)
class RecordedFacts:
    """What only a trial recording made by the recorder tells: ``mcap`` (its path, for the viewer files'
    images), ``summary`` (the recorder's, Start to Stop: ``duration_s``, cameras) and ``images`` (the images
    it holds per camera); ``completed_first``: the CompletionReport when the live pass recorded no keypoints
    at all and every recorded frame was detected from the images before anything else (else None)."""

    mcap: Path
    summary: dict
    images: RecordedImages
    completed_first: object | None = None


@dataclass(frozen=True, eq=False)
class TrialInput:
    """Everyone's 2D keypoints (``keypoints.recording``, (C, T, P, J, 3)), the rig they are calibrated
    by, and, for a trial recording, what the recorder measured (``recorded``; None for other inputs)."""

    keypoints: KeypointInput
    rig: Rig
    recorded: RecordedFacts | None = None

    @property
    def source(self) -> str:
        return self.keypoints.source


# ---------------------------------------------------------------------------------------------- options
# the trial's checks of its results, by name: (patient detections, rig, first stage's points mm) -> check dict
CHECKS = {"one_person": one_person_check, "rig": rig_check}
class ViewerFiles(enum.Enum):
    """Which stages get viewer files (.rrd, results MCAP): none, the last, every one."""

    NONE = "none"
    LAST = "last"
    EVERY = "every"


@dataclass(frozen=True)
class StagePlan:
    """One reconstruction stage: ``name`` (the trial's stage folder: preliminary | refined; any name when
    nothing is written), ``method`` (a :mod:`gaitcap.reconstruction.methods` config), ``label`` (the
    trajectory's method in words; default the method's name), ``chunked`` (robust triangulation on fixed
    chunks of frames, so a warm worker never recompiles: the clinic's preliminary stage)."""

    name: str
    method: object
    label: str | None = None
    chunked: bool = False


def default_stages(*, refine: bool = True) -> tuple[StagePlan, ...]:
    """The clinic's stages: preliminary (chunked robust triangulation) then, with ``refine``, refined
    (the default implicit trajectory fit)."""
    from gaitcap.reconstruction.methods import Implicit, Robust

    stages = (StagePlan("preliminary", Robust(), label="robust triangulation", chunked=True),)
    return stages + ((StagePlan("refined", Implicit(), label="implicit trajectory fit"),) if refine else ())


@dataclass(frozen=True, eq=False)
class TrialOptions:
    """What runs. ``stages``: the reconstruction stages in order; ``layout_check``: score the keypoint
    layouts (else the input's is used as it is); ``selector``: how to choose the patient (default: the
    clinician's stored choice, else automatic); ``choice``: the clinician's stored choice when nothing is
    written (``files`` None: reprocessing reads it from the trial's folder); ``kinematics``: joint kinematics of the last stage;
    ``age_years``: the patient's age (the kinematics band); ``viewer_files``: which stages get viewer
    files; ``criteria``: the data-quality thresholds; ``rerun``: the .rrd's settings; ``truth_mm``:
    ground-truth points (T, J, 3) mm for the methods' metrics (research), or None; ``checks``: the trial's
    checks of its results run on the first stage (names of :data:`CHECKS`), into the quality block;
    ``check_context``: what the checks compare with (the rig check's baseline trial);
    ``completion``: how the recorded frames without live keypoints are detected from the images before the
    last stage (:class:`~gaitcap.services.processing.completion.CompletionSettings`), or None."""

    stages: tuple[StagePlan, ...] = field(default_factory=default_stages)
    layout_check: bool = True
    selector: object | None = None
    choice: object | None = None
    kinematics: bool = True
    age_years: int | None = None
    viewer_files: ViewerFiles = ViewerFiles.LAST
    criteria: QualityCriteria = QualityCriteria()
    rerun: RerunSettings = RerunSettings()
    truth_mm: np.ndarray | None = None
    checks: tuple[str, ...] = tuple(CHECKS)
    check_context: CheckContext = CheckContext()
    completion: CompletionSettings | None = None

    def __post_init__(self) -> None:
        unknown = [c for c in self.checks if c not in CHECKS]
        if unknown:
            raise ValueError(f"checks: unknown {unknown}, known {sorted(CHECKS)}")
        if not self.stages:
            raise ValueError("stages: give at least one reconstruction stage")
        names = [s.name for s in self.stages]
        if len(set(names)) != len(names):
            raise ValueError(f"stages: each stage name once, got {names}")


# ---------------------------------------------------------------------------------------------- results
@dataclass(frozen=True, eq=False)
class StageOutcome:
    """One stage: its trajectory, gait report (or None and ``problem``), the joints with missing frames
    ({joint: count}), the files written ({artifact key: path}), and the method's
    :class:`~gaitcap.reconstruction.result.Reconstruction` when it ran unchunked (metrics, losses)."""

    name: str
    trajectory: Reconstruction
    report: object | None
    problem: str
    missing: dict[str, int]
    files: dict[str, str] = field(default_factory=dict)
    reconstruction: object | None = None
    gait_s: float = 0.0
    consistency: dict = field(default_factory=dict)  # the stage's consistency rules (ConsistencyReport dict)


@dataclass(frozen=True, eq=False)
class TrialResult:
    """A processed trial: the layout chosen, the patient's selection (None with one person in view), the
    cameras and frames used, the data quality, each stage's outcome, timings (s), the steps the options
    left out ({step: why}) and the later stages the data refused ({stage: why}; the earlier results stand)."""

    source: str
    layout: object  # LayoutChoice, or None without the layout check
    selection: object | None
    cameras: tuple[str, ...]
    frames: int
    quality: DataQuality
    stages: dict[str, StageOutcome]
    timings_s: dict[str, float]
    skipped: dict[str, str]
    kinematics: bool | None = None  # computed (True), unavailable (False), not run (None)
    failed: dict[str, str] = field(default_factory=dict)

    @property
    def last(self) -> StageOutcome:
        return list(self.stages.values())[-1]


# ---------------------------------------------------------------------------------------------- sinks
class TrialSink(Protocol):
    """Where a trial's results go besides its files (the catalog, the terminal)."""

    def progress(self, step: str, fraction: float, result: str | None) -> None:
        """A step starts (words), ``fraction`` of the trial done, the last stage stored (or None)."""

    def stored(self, outcome: StageOutcome, quality: DataQuality) -> None:
        """A stage's result is computed and its data files written."""

    def files_added(self, stage: str, files: dict[str, str]) -> None:
        """More files of a stage are written whole ({artifact key: path})."""

    def checked(self, quality: DataQuality) -> None:
        """The trial's checks of its results are done (``quality.checks``): the quality as it now stands."""

    def check(self) -> None:
        """Raise to stop processing (e.g. the job's lease was lost)."""


class NoSink:
    """Results stay in the files and the returned :class:`TrialResult`."""

    def progress(self, step: str, fraction: float, result: str | None) -> None:
        pass

    def stored(self, outcome: StageOutcome, quality: DataQuality) -> None:
        pass

    def files_added(self, stage: str, files: dict[str, str]) -> None:
        pass

    def checked(self, quality: DataQuality) -> None:
        pass

    def check(self) -> None:
        pass


# ---------------------------------------------------------------------------------------------- the path
def process_trial(data: TrialInput, options: TrialOptions = TrialOptions(), *, files: TrialFiles | None,
                  sink: TrialSink | None = None, fit_progress=None) -> TrialResult:
    """Process one trial (see the module docstring). ``files``: the trial's folder (None: nothing is
    written); ``sink``: where results go besides the files; ``fit_progress(done, total)`` during fits."""
    run = _TrialRun(data, options, files, sink or NoSink(), fit_progress)
    run.prepare()
    for index, plan in enumerate(options.stages):
        if options.completion is not None and index == len(options.stages) - 1:
            run.complete(index)
        if not run.stage_or_keep_earlier(index, plan):
            break
    if options.checks:
        run.check()
    run.kinematics()
    return run.result()


class _TrialRun:
    """The state of one :func:`process_trial`: what each step reads and leaves for the next."""

    def __init__(self, data: TrialInput, options: TrialOptions, files: TrialFiles | None, sink: TrialSink,
                 fit_progress) -> None:
        self.data, self.options, self.files, self.sink, self.fit_progress = data, options, files, sink, fit_progress
        self.timings: dict[str, float] = {}
        self.stages: dict[str, StageOutcome] = {}
        self.failed: dict[str, str] = {}  # later stages the data refused: {stage: why}
        self.kinematics_done: bool | None = None

    @contextlib.contextmanager
    def timed(self, name: str):
        t0 = time.perf_counter()
        yield
        self.timings[name] = time.perf_counter() - t0

    def prepare(self) -> None:
        """Usable input, the layout, the patient, the recording's data quality."""
        check_usable(self.data.keypoints.recording.patient())  # before anything is written
        with self.timed("layout"):
            self.recording, self.layout = _layout(self.data, self.options)
        with self.timed("association"):
            if _people_in_view(self.recording) > 1:
                self.sink.progress("finding the patient among the people in view", 0.07, None)
            self._choose_patient()
        self.quality = trial_quality(self.data, self.recording, self.det, self.rig, self.options.criteria)
        first = self.data.recorded.completed_first if self.data.recorded is not None else None
        if first is not None:
            self._completed_first(first)

    def _completed_first(self, report) -> None:
        """A recording without live keypoints, detected whole from its images: said and stored."""
        from gaitcap.services.processing.completion import save_completion

        check = completion_check(report)
        said = ("No live keypoints were recorded (the live detector caught nothing): every frame was detected "
                "from the recorded images after Stop")
        self.quality = with_check(self.quality, "completion", {**check, "warnings": [said, *check["warnings"]]})
        if self.files is not None:
            save_completion(self.files.root, self.recording, report)

    def _choose_patient(self) -> None:
        self.det, self.rig, self.selection = patient_input(self.recording, self.data.rig, files=self.files,
                                                           choice=self.options.choice, selector=self.options.selector)

    def complete(self, index: int) -> None:
        """The recorded frames without live keypoints detected from the images (a trial recording only;
        not again for one detected whole before processing)."""
        if self.data.recorded is None or self.data.recorded.completed_first is not None:
            return
        self.sink.progress("detecting the frames the live pass missed", _start(index, self.options), _last(self.stages))
        with self.timed("completion"):
            self.recording, report = _completed(self.data, self.recording, self.files, self.options)
            self._choose_patient()
            self.quality = with_check(self.quality, "completion", completion_check(report))

    def stage_or_keep_earlier(self, index: int, plan: StagePlan) -> bool:
        """:meth:`stage`; a later stage that the data refuse (ValueError: e.g. a fit that refuses a joint
        seen by one camera) leaves the earlier stages' results standing, says so in the trial's quality
        (a warning: the trial is not ``done``) and ends the stages (False). The first stage's failure is
        the trial's."""
        if index == 0:
            self.stage(index, plan)
            return True
        try:
            self.stage(index, plan)
            return True
        except ValueError as exc:
            kept = _last(self.stages)
            log.error("%s stage failed, the %s results stand: %s", plan.name, kept, exc)
            self.failed[plan.name] = str(exc)
            self.quality = with_check(self.quality, "stages", {
                "warnings": [f"The {plan.name} reconstruction failed ({exc}); the {kept} results are shown"],
                "notes": [], "failed": dict(self.failed)})
            self.sink.checked(self.quality)
            return False

    def stage(self, index: int, plan: StagePlan) -> None:
        """One reconstruction stage: its trajectory, then gait, files and the sink."""
        self.sink.progress(_STARTING.get(plan.name, f"reconstruction: {plan.name}"), _start(index, self.options),
                           _last(self.stages))
        with self.timed(plan.name):
            traj, rec = run_stage(plan, self.det, self.rig, fit_progress=self.fit_progress,
                                  truth_mm=self.options.truth_mm)
            if "completion" in self.quality.checks:
                traj = replace(traj, method=f"{traj.method} (keypoints completed after Stop)")
        self.sink.check()
        if index == 0:
            self.quality = with_reprojection(self.quality, reprojection_px(traj.points_mm, self.det.one_person, self.rig))
            self.first = (self.det, self.rig, traj.points_mm)  # what the checks judge, completion or not
        viewers = (self.recording, self.rig) if _wants_viewers(self.options, index) else None
        with self.timed(f"{plan.name} gait and files"):
            self.stages[plan.name], self.quality = _finish_stage(
                plan.name, traj, rec, self.det, self.files, self.sink, self.quality, viewers=viewers, data=self.data,
                options=self.options)

    def check(self) -> None:
        """The trial's checks of its results on the first stage's points: the quality, ``checks.json`` and
        ``sink.checked``."""
        self.sink.progress("checking the rig and the reconstruction", 0.96, _last(self.stages))
        with self.timed("checks"):
            self.quality = checked_quality(self.quality, *self.first, self.options.checks, self.options.check_context)
        if self.files is not None:
            write_checks(self.files, self.quality)
            if "rig" in self.options.checks:
                write_rig_keypoints(self.files, self.first[0])
        self.sink.checked(self.quality)

    def kinematics(self) -> None:
        if self.options.kinematics and self.files is not None:
            with self.timed("kinematics"):
                self.kinematics_done = _kinematics(self.files, list(self.stages.values())[-1], self.options.age_years)

    def result(self) -> TrialResult:
        return TrialResult(self.data.source, self.layout, self.selection, tuple(self.det.camera_names),
                           int(self.det.shape[1]), self.quality, self.stages, self.timings,
                           _skipped(self.options, self.files, self.data), self.kinematics_done, dict(self.failed))


_STARTING = {"preliminary": "first 3D reconstruction", "refined": "refining the 3D reconstruction"}


def _start(index: int, options: TrialOptions) -> float:
    """Fraction of the trial done when stage ``index`` starts (0.1 .. 0.9)."""
    return round(0.1 + 0.3 * index if len(options.stages) == 2 else 0.1 + 0.8 * index / len(options.stages), 3)


def _completed(data: TrialInput, recording, files: TrialFiles | None, options: TrialOptions):
    """Every recorded frame without live keypoints detected from the recording's images, stored with its
    provenance when ``files``: (the complete keypoints, the CompletionReport)."""
    from gaitcap.services.processing.completion import complete_with, save_completion

    completed, report = complete_with(data.recorded.mcap, recording, options.completion)
    if files is not None:
        save_completion(files.root, completed, report)
    return completed, report


def _last(stages: dict[str, StageOutcome]) -> str | None:
    return list(stages)[-1] if stages else None


def _skipped(options: TrialOptions, files: TrialFiles | None, data: TrialInput) -> dict[str, str]:
    """{step: why} for each step the options (or the input) left out."""
    out = {}
    if not options.layout_check:
        out["layout check"] = "layout_check=False: the input's layout is used as it is"
    if not options.kinematics:
        out["kinematics"] = "kinematics=False"
    out.update({f"{name} check": f"checks={list(options.checks)}" for name in CHECKS if name not in options.checks})
    if options.completion is None:
        out["completion"] = "completion=None: the stages use the live keypoints"
    elif data.recorded is None:
        out["completion"] = "the input is no trial recording: no images to complete the keypoints from"
    if files is None:
        out["files"] = "no output folder: nothing written"
    elif options.viewer_files is ViewerFiles.NONE:
        out["viewer files"] = "viewer_files=none"
    return out


def _layout(data: TrialInput, options: TrialOptions):
    """The recording in its keypoint layout and the choice (None when the check is left out)."""
    if not options.layout_check:
        return data.keypoints.recording, None
    return resolve_layout(data.keypoints.recording, data.rig, named=data.keypoints.layout)


def _people_in_view(recording) -> int:
    from gaitcap.services.processing.people import most_people_in_view

    return most_people_in_view(recording)


def _wants_viewers(options: TrialOptions, index: int) -> bool:
    last = index == len(options.stages) - 1
    return options.viewer_files is ViewerFiles.EVERY or (options.viewer_files is ViewerFiles.LAST and last)


def write_checks(files: TrialFiles, quality: DataQuality) -> None:
    """``checks.json`` in the trial's folder: each check of its results by name (JSON, written whole)."""
    import json

    from gaitcap.acquisition.fileio import atomic_write_text
    from gaitcap.reconstruction.jsonable import json_ready

    atomic_write_text(files.checks_json, json.dumps(json_ready(quality.checks), indent=1) + "\n")


def checked_quality(quality: DataQuality, det, rig: Rig, points_mm: np.ndarray, checks,
                    context: CheckContext = CheckContext()) -> DataQuality:
    """The quality with the trial's ``checks`` (names of :data:`CHECKS`) of the first stage's points
    (T, J, 3) mm."""
    for name in checks:
        quality = with_check(quality, name, CHECKS[name](det, rig, points_mm, context))
    return quality


def write_rig_keypoints(files: TrialFiles, det) -> None:
    """The patient's keypoints of the frames the rig check judges, for later trials' rig checks."""
    from gaitcap.acquisition.writers import save_detections_npz
    from gaitcap.reconstruction.calibration.rig_check import checked_frames

    save_detections_npz(det.frames(checked_frames(det.shape[1])), files.rig_keypoints_npz)


def trial_quality(data: TrialInput, recording, det, rig: Rig, criteria: QualityCriteria) -> DataQuality:
    """The recording's data quality: cameras, timing, the patient's detections; a recorder's recording
    also judges the cameras by the images it holds and says when it was recovered."""
    from gaitcap.acquisition.recording.reader import frame_sets_held

    recorded = data.recorded
    images = recorded.images if recorded is not None else None
    quality = recording_quality(camera_names=recording.camera_names, timestamps_ns=recording.timestamps_ns,
                             patient_confidence=det.one_person[..., 2], expected_cameras=rig.names,
                             recorded_s=recorded.summary.get("duration_s") if recorded else None,
                             frame_ids=recording.frame_ids, recorded_frames=images.frames if images else None,
                             recovered=images.recovered if images else False,
                             recorder_dropped=images.dropped if images else None,
                             restarts=recording.restarts, ignored=recording.ignored, criteria=criteria)
    held = frame_sets_held(recording.timestamps_ns)
    if not held:
        return quality
    return with_check(quality, "frame_times", {"held_frame_sets": held, "warnings": [], "notes": [
        f"{held} of {recording.frame_ids.size} frame sets were stamped out of order (a camera's frame more than "
        "half a frame period off its slot): their times were held to the frame grid, moved by at most 0.45 "
        "frame period"]})


def run_stage(plan: StagePlan, det, rig: Rig, *, fit_progress=None, truth_mm=None) -> tuple[Reconstruction, Reconstruction | None]:
    """The stage's trajectory and the method's Reconstruction (None when chunked); NoUsableObservations
    when no joint could be reconstructed in any frame."""
    from gaitcap.reconstruction.methods import reconstruct

    t0 = time.perf_counter()
    if plan.chunked:
        traj, rec = preliminary(det, rig), None
    else:
        rec = reconstruct(det, rig, method=plan.method, progress=fit_progress, truth_mm=truth_mm)
        traj = trajectory_of(rec, method=plan.label, elapsed_s=time.perf_counter() - t0)
    if plan.label and traj.method != plan.label:
        traj = replace(traj, method=plan.label)
    if not np.isfinite(traj.points_mm).any():
        raise NoUsableObservations(f"{plan.name}: no joint could be reconstructed in any frame")
    return traj, rec


def _finish_stage(name: str, traj: Reconstruction, rec, det, files: TrialFiles | None, sink: TrialSink,
                  quality: DataQuality, *, viewers, data: TrialInput,
                  options: TrialOptions) -> tuple[StageOutcome, DataQuality]:
    """Gait, the steps it could not count into the quality (the ``steps`` check), the stage's data files,
    ``sink.stored``, then its views and viewer files; the outcome and the quality as it now stands."""
    from gaitcap.services.processing.outputs import write_data, write_views
    from gaitcap.services.processing.steps_check import steps_check

    t0 = time.perf_counter()
    report, problem = gait_of(traj)
    if problem:
        log.warning("%s: no gait parameters: %s", name, problem)
    quality = with_check(quality, "steps", steps_check(name, report))
    consistency = stage_consistency(report, traj.times_s)
    if consistency.get("failures"):
        log.warning("%s: %d consistency rule(s) failed: the parameters concerned are in doubt", name,
                    len(consistency["failures"]))
    missing = missing_counts(traj)
    if missing:
        log.warning("%s: joints missing in some frames: %s", name,
                    ", ".join(f"{j} ({n} of {traj.points_mm.shape[0]})" for j, n in missing.items()))
    gait_s = time.perf_counter() - t0
    written = {} if files is None else write_data(files, name, traj, report, data_quality=quality.to_dict(),
                                                  consistency=consistency)
    outcome = StageOutcome(name, traj, report, problem, missing, dict(written), rec, gait_s, consistency)
    sink.stored(outcome, quality)
    if files is None:
        return outcome, quality
    sink.progress(f"saving the {name} files", 0.35 if name == "preliminary" else 0.95, name)
    views = write_views(files, name, traj, report, trial_id=files.root.name)
    sink.files_added(name, views)
    written.update(views)
    if viewers is not None:
        shown = _viewer_files(files, name, traj, det, report, viewers, data, options)
        sink.files_added(name, shown)
        written.update(shown)
    return replace(outcome, files=written), quality


def _viewer_files(files: TrialFiles, name: str, traj: Reconstruction, det, report, viewers, data: TrialInput,
                  options: TrialOptions) -> dict[str, str]:
    from gaitcap.services.processing.viewers.files import trial_view, write_viewer_files

    recording, rig = viewers
    mcap = data.recorded.mcap if data.recorded is not None else None
    view = trial_view(files.root.name, traj, detections=det, keypoints=recording, rig=rig, report=report,
                      recording=mcap, bones=det.skeleton.bone_indices)
    return {k: str(p) for k, p in write_viewer_files(files, name, view, options.rerun).items()}


def missing_counts(traj: Reconstruction) -> dict[str, int]:
    """Joint name -> frames where the trajectory has no point, for joints with some."""
    gone = ~np.isfinite(traj.points_mm).all(-1)  # (T, J)
    return {n: int(gone[:, j].sum()) for j, n in enumerate(traj.joint_names) if gone[:, j].any()}


def _kinematics(files: TrialFiles, stage: StageOutcome, age_years: int | None) -> bool:
    from gaitcap.services.processing.kinematics_step import kinematics_step

    return kinematics_step(files, stage.name, stage.trajectory, age_years=age_years)


# ---------------------------------------------------------------------------------------------- inputs
def recording_input(mcap: Path, *, fallback_calibration: Path | None = None,
                    completion: CompletionSettings | None = None) -> TrialInput:
    """A trial recording made by the recorder as a :class:`TrialInput` (the worker's): everyone's
    keypoints, the calibration recorded in it (else ``fallback_calibration``), what the recorder measured.

    A recording whose live pass recorded no keypoint at all (the detector node down for the whole trial)
    is detected from its images with ``completion`` (the trial then says so); without it the error says
    that the images are kept and how to detect them."""
    from gaitcap.acquisition.recording.reader import NoKeypointsRecorded, read_keypoints
    from gaitcap.services.processing.completion import complete_with
    from gaitcap.services.processing.pipeline import recorded_rig

    first = None
    try:
        recording = read_keypoints(mcap)  # first: a file that is no recording is named as such
    except NoKeypointsRecorded as exc:
        if completion is None:
            raise NoKeypointsRecorded(f"{exc}; its images are kept: a worker with --complete-with, or gaitcap "
                                      "redetect, detects them") from None
        log.warning("%s: no live keypoints recorded: detecting every recorded frame with %s", mcap,
                    completion.detector_name)
        recording, first = complete_with(mcap, None, completion)
    rig = recorded_rig(mcap, fallback_calibration=fallback_calibration)
    keypoints = KeypointInput(recording, recording.skeleton.name, rig, "trial MCAP")
    return TrialInput(keypoints, rig, replace(recorded_facts(mcap, recording), completed_first=first))


def recorded_facts(mcap: Path, recording) -> RecordedFacts:
    """The recorder's summary of a trial MCAP (Start to Stop, images per camera) and the images it holds,
    placed on ``recording``'s (its keypoints') frame grid."""
    from gaitcap.acquisition.recording.reader import read_summary
    from gaitcap.services.processing.recorded_images import recorded_images

    summary = read_summary(mcap)
    return RecordedFacts(Path(mcap), summary, recorded_images(mcap, summary, recording))


def is_trial_recording(path: Path) -> bool:
    """A recorder's trial MCAP (a file ending in .mcap)."""
    return Path(path).is_file() and Path(path).suffix.lower() == ".mcap"

