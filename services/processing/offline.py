"""Recordings made elsewhere, processed as the worker processes a trial: the offline twin of the clinic's
Stop button (``gaitcap process``), an adapter of the one processing path
(:func:`~gaitcap.services.processing.trial.process_trial`).

It chooses the input (videos detected here, a trial MCAP with what its recorder measured, keypoint files,
other tools' folders: :func:`load_input`), the options (:class:`OfflineOptions` -> :class:`TrialOptions`)
and where results go (``OUT/<stage>/``, ``people.json`` when several people were in view); the steps and
their order are the worker's.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from gaitcap.acquisition.importers.keypoint_files import read_keypoints_input
from gaitcap.acquisition.importers.keypoint_input import KeypointInput
from gaitcap.acquisition.recording.reader import NoKeypointsRecorded
from gaitcap.reconstruction.result import Reconstruction
from gaitcap.services.processing.artifacts import TrialFiles
from gaitcap.services.processing.trial import (
    TrialInput,
    TrialOptions,
    TrialResult,
    default_stages,
    is_trial_recording,
    process_trial,
    recorded_facts,
    recording_input,
)

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PatientRequest:
    """Who the patient is among several people: ``track_id`` (``--person``), or the person nearest the
    floor point ``near_mm`` (x, y mm; ``--patient-near``) in their first seconds; else automatic."""

    track_id: int | None = None
    near_mm: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if self.track_id is not None and self.near_mm is not None:
            raise ValueError("give at most one of --person and --patient-near")
        if self.track_id is not None and self.track_id < 0:
            raise ValueError(f"--person: a track id >= 0, got {self.track_id}")

    def selector(self):
        from gaitcap.reconstruction.association import ManualTrack, NearestStartTrack

        if self.track_id is not None:
            return ManualTrack(self.track_id)
        if self.near_mm is not None:
            return NearestStartTrack(start_mm=(float(self.near_mm[0]), float(self.near_mm[1]), 0.0))
        return None


@dataclass(frozen=True)
class OfflineOptions:
    """skeleton: layout name (wins over the input's and the recognised one); fps: frame rate when the
    input has none; refine: also run the implicit fit; patient: :class:`PatientRequest`; kinematics:
    joint kinematics of the last stage."""

    skeleton: str | None = None
    fps: float = 30.0
    refine: bool = True
    patient: PatientRequest = PatientRequest()
    kinematics: bool = True
    completion: object | None = None  # a trial MCAP: its frames without live keypoints detected (CompletionPlan)

    def trial_options(self) -> TrialOptions:
        """The one path's options: the worker's, less what was asked to be left out."""
        return TrialOptions(stages=default_stages(refine=self.refine), selector=self.patient.selector(),
                            kinematics=self.kinematics, completion=self.completion if self.refine else None)


def result_summary(result: TrialResult, *, chosen_how: str) -> dict:
    """JSON-ready summary of a processed input (the ``--json`` output): layout, people, each stage's
    summary, the data-quality block, timings, the steps left out and the later stages the data refused."""
    from gaitcap.services.processing.outputs import summary_of

    people = None
    if result.selection is not None:
        people = {"tracks": int(result.selection.tracks.num_tracks), "patient_track_id": int(result.selection.track_id),
                  "chosen_by": chosen_how, "lines": people_lines(result.selection, how=chosen_how)}
    layout = None if result.layout is None else {"skeleton": result.layout.skeleton, "how": result.layout.how,
                                                 "evidence": result.layout.evidence(),
                                                 "warnings": list(result.layout.warnings)}
    return {"source": result.source, "layout": layout, "cameras": list(result.cameras), "frames": result.frames,
            "people": people, "data_quality": result.quality.to_dict(),
            "stages": {name: {"method": s.trajectory.method, "problem": s.problem,
                              "missing_frames_per_joint": s.missing, "missing_frames": missing_frames(s.trajectory),
                              "files": s.files, "summary": summary_of(s.report) if s.report is not None else {}}
                       for name, s in result.stages.items()},
            "skipped": dict(result.skipped), "failed": dict(result.failed), "timings_s": {k: round(v, 3) for k, v in result.timings_s.items()}}


def people_lines(selection, *, how: str) -> list[str]:
    """Who was tracked and who was chosen, one line per track (``how``: why that one)."""
    lines = []
    for t in selection.tracks.summaries():
        mark = "*" if t.track_id == selection.track_id else " "
        lines.append(f"{mark} track {t.track_id}: {t.frames} frames ({t.first_s:.2f}-{t.last_s:.2f} s), "
                     f"{t.mean_views:.1f} cameras on average, walked {t.path_mm / 1000:.2f} m")
    lines.append(f"the patient is track {selection.track_id} ({how})")
    return lines


def choice_reason(request: PatientRequest) -> str:
    if request.track_id is not None:
        return f"--person {request.track_id}"
    if request.near_mm is not None:
        return f"--patient-near: nearest ({request.near_mm[0]:g}, {request.near_mm[1]:g}) mm early on"
    return "automatic: the person who walks the walkway"


def frame_ranges(frames: np.ndarray) -> str:
    """Frame indices -> "0-5, 40-61"."""
    if frames.size == 0:
        return ""
    breaks = np.flatnonzero(np.diff(frames) > 1)
    starts, ends = np.r_[frames[0], frames[breaks + 1]], np.r_[frames[breaks], frames[-1]]
    return ", ".join(f"{a}" if a == b else f"{a}-{b}" for a, b in zip(starts, ends, strict=True))


def missing_by_joint(points_mm: np.ndarray, joint_names) -> dict[str, np.ndarray]:
    """Joint name -> the frame indices where ``points_mm`` (T, J, 3) has no point, for joints with some."""
    gone = ~np.isfinite(points_mm).all(-1)  # (T, J)
    return {n: np.flatnonzero(gone[:, j]) for j, n in enumerate(joint_names) if gone[:, j].any()}


def missing_frames(traj: Reconstruction) -> dict[str, str]:
    """Joint name -> the frames (ranges) where the trajectory has no point, for joints with some."""
    return {n: frame_ranges(f) for n, f in missing_by_joint(traj.points_mm, traj.joint_names).items()}


# ---------------------------------------------------------------------------------------------- input
def _has_videos(path: Path) -> bool:
    from gaitcap.acquisition.video_detect import VIDEO_SUFFIXES

    return path.is_dir() and any(p.suffix.lower() in VIDEO_SUFFIXES for p in path.iterdir() if p.is_file())


def detect_input(path: Path, detector, *, fps: float | None, on_frame: Callable[[], None] | None) -> KeypointInput:
    """Everyone in every frame of a folder of videos (one per camera) -> a keypoint input."""
    from gaitcap.acquisition.video_detect import detect_videos, find_videos

    found = detect_videos(find_videos(path), detector, fps=fps, on_frame=on_frame)
    return KeypointInput(found, found.skeleton.name, None, f"videos ({found.fps_hz:g} fps, {found.skeleton.name})")


def load_input(path: Path, *, calibration: Path | None, options: OfflineOptions, detector_factory=None,
               on_frame: Callable[[], None] | None = None) -> TrialInput:
    """The input as the one path takes it (``calibration`` wins over one carried by the input); a trial
    MCAP comes with what its recorder measured, so it is judged as the clinic judges it."""
    from gaitcap.acquisition.importers.tool_folders import (
        load_calibration,
        pose2sim_calibration,
        pose2sim_videos,
    )

    user_rig = load_calibration(calibration) if calibration is not None else None
    videos = path if _has_videos(path) else pose2sim_videos(path)
    if videos is not None:
        if detector_factory is None:
            raise ValueError(f"{videos}: a folder of videos needs a detector (--detector)")
        data = detect_input(videos, detector_factory(), fps=None, on_frame=on_frame)
        if videos != path:  # a Pose2Sim project before its pose estimation: its calibration
            data = replace(data, rig=pose2sim_calibration(path))
    else:
        try:
            data = read_keypoints_input(path, rig=user_rig, fps=options.fps, skeleton=options.skeleton)
        except NoKeypointsRecorded:  # a trial MCAP whose live pass caught nothing: detected from its images
            if options.completion is None or not is_trial_recording(path):
                raise
            whole = recording_input(path, fallback_calibration=calibration, completion=options.completion)
            return replace(whole, rig=user_rig) if user_rig is not None else whole
    rig = user_rig or data.rig
    if rig is None:
        raise ValueError(f"{path} ({data.source}) carries no calibration: give --calibration")
    missing = [n for n in data.recording.camera_names if n not in rig.names]
    if missing:
        raise ValueError(f"cameras {missing} of {path} are not in the calibration (cameras {list(rig.names)})")
    recorded = recorded_facts(path, data.recording) if is_trial_recording(path) else None
    return TrialInput(data, rig, recorded)


# ---------------------------------------------------------------------------------------------- process
class StageNotifier:
    """A sink that tells the caller as each step starts (``on_stage(words)``); results stay in the files."""

    def __init__(self, on_stage: Callable[[str], None] | None) -> None:
        self.on_stage = on_stage or (lambda _step: None)

    def progress(self, step: str, fraction: float, result: str | None) -> None:
        self.on_stage(step)

    def stored(self, outcome, quality) -> None:
        pass

    def files_added(self, stage: str, files: dict[str, str]) -> None:
        pass

    def checked(self, quality) -> None:
        pass

    def check(self) -> None:
        pass


def process_input(data: TrialInput, out: Path, *, options: OfflineOptions = OfflineOptions(),
                  on_stage: Callable[[str], None] | None = None, fit_progress=None,
                  timings_s: dict[str, float] | None = None) -> TrialResult:
    """The one processing path on an input already read; files under ``out`` (the worker's names).
    ``on_stage(words)`` is called as each step starts; ``fit_progress(done, total)`` during the fit."""
    result = process_trial(data, options.trial_options(), files=TrialFiles(Path(out)), sink=StageNotifier(on_stage),
                           fit_progress=fit_progress)
    if result.selection is not None:
        for line in people_lines(result.selection, how=choice_reason(options.patient)):
            log.info("%s", line)
    return replace(result, timings_s={**(timings_s or {}), **result.timings_s})
