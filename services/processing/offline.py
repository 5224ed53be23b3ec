"""Recordings made elsewhere, processed as the worker processes a trial: the offline twin of the clinic's
Stop button (``gaitcap process``).

input (videos, trial MCAP, keypoint files, other tools' folders) -> everyone's 2D keypoints -> layout
(:func:`~gaitcap.services.processing.pipeline.resolve_layout`) -> the patient
(:func:`~gaitcap.services.processing.pipeline.patient_input`, the worker's association and choice) ->
preliminary (robust triangulation) and refined (implicit fit) trajectories -> gait
(:func:`~gaitcap.services.processing.pipeline.gait_of`) -> the worker's files for each stage
(:mod:`gaitcap.services.processing.outputs`, viewer files) in ``OUT/<stage>/``, and ``people.json`` when
several people were in view.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from gaitcap.acquisition.keypoint_files import read_keypoints_input
from gaitcap.acquisition.keypoint_input import KeypointInput, make_input
from gaitcap.reconstruction.camera import Rig
from gaitcap.services.processing.artifacts import TrialFiles
from gaitcap.services.processing.pipeline import (
    NoUsableObservations,
    Trajectory,
    check_usable,
    gait_of,
    patient_input,
    preliminary,
    refined,
    resolve_layout,
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
    input has none; refine: also run the implicit fit; patient: :class:`PatientRequest`."""

    skeleton: str | None = None
    fps: float = 30.0
    refine: bool = True
    patient: PatientRequest = PatientRequest()


@dataclass(frozen=True, eq=False)
class StageResult:
    """One stage: trajectory, gait report (or None and the problem), joints with missing frames, files."""

    trajectory: Trajectory
    report: object | None
    problem: str
    missing: dict[str, int]
    missing_frames: dict[str, str]
    files: dict[str, str]


@dataclass(frozen=True, eq=False)
class OfflineResult:
    source: str
    layout: object  # LayoutChoice
    selection: object | None  # PatientSelection, None with one person in view
    cameras: tuple[str, ...]
    frames: int
    stages: dict[str, StageResult]
    timings_s: dict[str, float] = field(default_factory=dict)
    chosen_how: str = ""

    def summary(self) -> dict:
        """JSON-ready summary (the ``--json`` output)."""
        from gaitcap.services.processing.outputs import summary_of

        people = None
        if self.selection is not None:
            people = {"tracks": int(self.selection.tracks.num_tracks), "patient_track_id": int(self.selection.track_id),
                      "chosen_by": self.chosen_how, "lines": people_lines(self.selection, how=self.chosen_how)}
        return {"source": self.source, "layout": {"skeleton": self.layout.skeleton, "how": self.layout.how,
                                                  "evidence": self.layout.evidence(),
                                                  "warnings": list(self.layout.warnings)},
                "cameras": list(self.cameras), "frames": self.frames, "people": people,
                "stages": {name: {"method": s.trajectory.method, "problem": s.problem,
                                  "missing_frames_per_joint": s.missing, "missing_frames": s.missing_frames,
                                  "files": s.files,
                                  "summary": summary_of(s.report) if s.report is not None else {}}
                           for name, s in self.stages.items()},
                "timings_s": {k: round(v, 3) for k, v in self.timings_s.items()}}


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


def missing_frames(traj: Trajectory) -> dict[str, str]:
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
    return make_input(found.people, found.camera_names, found.times_s, layout=found.skeleton, rig=None,
                      source=f"videos ({found.fps:g} fps, {found.skeleton})")


def load_input(path: Path, *, calibration: Path | None, options: OfflineOptions, detector_factory=None,
               on_frame: Callable[[], None] | None = None) -> tuple[KeypointInput, Rig]:
    """The keypoint input and the rig (``calibration`` wins over one carried by the input)."""
    from gaitcap.acquisition.tool_folders import load_calibration, pose2sim_calibration, pose2sim_videos

    user_rig = load_calibration(calibration) if calibration is not None else None
    videos = path if _has_videos(path) else pose2sim_videos(path)
    if videos is not None:
        if detector_factory is None:
            raise ValueError(f"{videos}: a folder of videos needs a detector (--detector)")
        data = detect_input(videos, detector_factory(), fps=None, on_frame=on_frame)
        if videos != path:  # a Pose2Sim project before its pose estimation: its calibration
            data = replace(data, rig=pose2sim_calibration(path))
    else:
        data = read_keypoints_input(path, rig=user_rig, fps=options.fps, skeleton=options.skeleton)
    rig = user_rig or data.rig
    if rig is None:
        raise ValueError(f"{path} ({data.source}) carries no calibration: give --calibration")
    missing = [n for n in data.recording.camera_names if n not in rig.names]
    if missing:
        raise ValueError(f"cameras {missing} of {path} are not in the calibration (cameras {list(rig.names)})")
    return data, rig


# ---------------------------------------------------------------------------------------------- process
def _stage(files: TrialFiles, name: str, traj: Trajectory, det, *, recording, rig: Rig, trial_id: str) -> StageResult:
    from gaitcap.services.processing.outputs import write_data, write_views
    from gaitcap.services.processing.viewers.files import trial_view, write_viewer_files

    report, problem = gait_of(traj)
    if problem:
        log.warning("%s: no gait parameters: %s", name, problem)
    missing = {n: int(f.size) for n, f in missing_by_joint(traj.points_mm, traj.joint_names).items()}
    if missing:
        log.warning("%s: joints missing in some frames: %s", name,
                    ", ".join(f"{j} ({n} of {traj.points_mm.shape[0]})" for j, n in missing.items()))
    write_data(files, name, traj, report)
    write_views(files, name, traj, report, trial_id=trial_id)
    write_viewer_files(files, name, trial_view(trial_id, traj, detections=det, keypoints=recording, rig=rig,
                                               report=report, recording=None, bones=det.skeleton.bone_indices))
    return StageResult(traj, report, problem, missing, missing_frames(traj), files.existing(name))


def process_input(data: KeypointInput, rig: Rig, out: Path, *, options: OfflineOptions = OfflineOptions(),
                  on_stage: Callable[[str], None] | None = None, fit_progress=None,
                  timings_s: dict[str, float] | None = None) -> OfflineResult:
    """Run the processing path on an input already read (see the module docstring); files under ``out``.
    ``on_stage(name)`` is called as each stage starts; ``fit_progress(done, total)`` during the fit."""
    timings = dict(timings_s or {})
    notify = on_stage or (lambda _name: None)
    files = TrialFiles(Path(out))
    check_usable(data.recording.patient())  # before anything is written
    t0 = time.perf_counter()
    notify("layout")
    recording, layout = resolve_layout(data.recording, rig, named=data.layout)
    timings["layout"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    notify("patient")
    det, rig_used, selection = patient_input(recording, rig, files=files, selector=options.patient.selector())
    if selection is not None:
        for line in people_lines(selection, how=choice_reason(options.patient)):
            log.info("%s", line)
    timings["association"] = time.perf_counter() - t0
    stages = {}
    runs = [("preliminary", lambda: preliminary(det, rig_used))]
    if options.refine:
        runs.append(("refined", lambda: refined(det, rig_used, progress=fit_progress)))
    for name, run in runs:
        t0 = time.perf_counter()
        notify(name)
        traj = run()
        if not np.isfinite(traj.points_mm).any():
            raise NoUsableObservations(f"{name}: no joint could be reconstructed in any frame")
        timings[name] = time.perf_counter() - t0
        t0 = time.perf_counter()
        stages[name] = _stage(files, name, traj, det, recording=recording, rig=rig_used, trial_id=files.root.name)
        timings[f"{name} gait and files"] = time.perf_counter() - t0
    return OfflineResult(data.source, layout, selection, tuple(det.camera_names), int(det.shape[1]), stages, timings,
                         choice_reason(options.patient))

