"""The viewer files of one processing stage: ``trajectory.rrd`` (Rerun) and ``results.mcap`` (Foxglove),
written by the worker right after the stage's result is stored (the .rrd in a child process,
:mod:`~gaitcap.services.processing.viewers.apart`, so that Rerun's memory does not stay in the worker)."""

from __future__ import annotations

import logging
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.result import Reconstruction
from gaitcap.services.processing.artifacts import TrialFiles
from gaitcap.services.processing.viewers.apart import write_rrd_apart
from gaitcap.services.processing.viewers.rerun_trial import RerunSettings
from gaitcap.services.processing.viewers.results_mcap import write_results_mcap
from gaitcap.services.processing.viewers.trial_view import TrialView, joint_confidence, start_ns_of

log = logging.getLogger(__name__)

VIEWER_FILES = ("rerun_rrd", "results_mcap")


def trial_view(trial_id: str, traj: Reconstruction, *, detections, keypoints, rig: Rig, report, recording: Path | None,
               bones) -> TrialView:
    """A :class:`TrialView` of one stage: its trajectory, the patient's detections (for per-joint
    confidence), everyone's keypoints and the recording (for images and 2D), the rig and gait report."""
    traj = replace(traj, points_mm=np.asarray(traj.points_mm, dtype=np.float64),
                   times_s=np.asarray(traj.times_s, dtype=np.float64), joint_names=tuple(traj.joint_names))
    return TrialView(trial_id=trial_id, trajectory=traj, bones=np.asarray(bones, dtype=np.int64), rig=rig,
                     start_ns=start_ns_of(keypoints), confidence=joint_confidence(detections, traj.points_mm.shape[0]),
                     report=report, recording=recording, keypoints=keypoints)


def write_viewer_files(files: TrialFiles, stage: str, view: TrialView,
                       settings: RerunSettings = RerunSettings()) -> dict[str, Path]:
    """Write the stage's .rrd and results MCAP; artifact key -> path of those written.

    The trial's results are stored before: a viewer file that cannot be written (an unreadable recording,
    a full disk) is logged as an error with its cause and left out, and the trial stays done."""
    t0 = time.perf_counter()
    writers = {"rerun_rrd": lambda path: write_rrd_apart(path, view, settings),  # Rerun's memory goes with it
               "results_mcap": lambda path: write_results_mcap(path, view)}
    out = {}
    for key, write in writers.items():
        path = files.stage_file(stage, key)
        try:
            out[key] = write(path)
        except Exception:
            log.exception("trial %s %s: %s not written", view.trial_id, stage, path.name)
    log.info("trial %s %s: viewer files in %.2f s", view.trial_id, stage, time.perf_counter() - t0)
    return out
