"""Re-detect many stored trials with one detector: one trial per task on an executor (this process, a local
process pool or a Ray cluster: :mod:`gaitcap.services.research.executors`).

Each task completes one trial's recording with :func:`~gaitcap.services.processing.completion.complete_trial`
(every recorded frame, or only those without live keypoints), its detector in the task's own process, and
writes ``keypoints_complete.npz`` and ``completion.json`` into the trial's output folder. A trial that
cannot be done (file missing, corrupt beyond reading) fails alone, with the reason in its outcome.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from pathlib import Path

from gaitcap.services.processing.completion import CompletionSettings

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class RedetectTask:
    """One trial: its recording, the folder for its files, how to detect (``only_missing``: keep the live
    keypoints)."""

    mcap: str
    out_dir: str
    settings: CompletionSettings
    only_missing: bool = False


@dataclass(frozen=True)
class RedetectOutcome:
    """``status`` done | failed; ``report``: the completion report (``CompletionReport.to_dict()``) when done."""

    mcap: str
    out_dir: str
    status: str
    error: str | None = None
    report: dict | None = None

    def to_dict(self) -> dict:
        return {"mcap": self.mcap, "out_dir": self.out_dir, "status": self.status, "error": self.error,
                "report": self.report}


def trial_folder_name(mcap: str | os.PathLike) -> str:
    """A trial's output folder name: its folder's name for ``.../<trial>/recording.mcap``, else the file's stem."""
    p = Path(mcap)
    stem = p.name.removesuffix(".part").removesuffix(".mcap")
    return p.parent.name if stem == "recording" and p.parent.name else stem


def redetect_one(task: RedetectTask) -> RedetectOutcome:
    """Complete one trial (never raises for the trial's own problems: they are its outcome)."""
    from gaitcap.acquisition.recording.reader import read_keypoints, resolve_recording
    from gaitcap.services.processing.completion import complete_trial

    try:
        path = resolve_recording(task.mcap)
        live = None
        if task.only_missing:
            try:
                live = read_keypoints(path)
            except ValueError as exc:
                if "no keypoints recorded" not in str(exc):
                    raise
        settings = replace(task.settings, redetect_all=not task.only_missing)
        _, report, _ = complete_trial(path, live, task.out_dir, settings)
        return RedetectOutcome(task.mcap, task.out_dir, "done", report=report.to_dict())
    except Exception as exc:  # the trial's own problem, reported in its outcome
        log.warning("redetect %s failed: %s", task.mcap, exc)
        return RedetectOutcome(task.mcap, task.out_dir, "failed", error=f"{type(exc).__name__}: {exc}")


def plan_redetect(mcaps: Iterable[str | os.PathLike], out_root: str | os.PathLike, settings: CompletionSettings, *,
                  only_missing: bool = False) -> list[RedetectTask]:
    """One task per recording, each into ``out_root/<trial>`` (ValueError when two trials share a name); the
    detector runs in the task's process (the executor spreads the trials over processes)."""
    tasks, seen = [], {}
    for mcap in mcaps:
        name = trial_folder_name(mcap)
        if name in seen:
            raise ValueError(f"trials {seen[name]} and {mcap} would both write into {Path(out_root) / name}")
        seen[name] = str(mcap)
        tasks.append(RedetectTask(str(mcap), str(Path(out_root) / name), replace(settings, workers=0), only_missing))
    return tasks


def run_redetect(tasks: list[RedetectTask], executor,
                 on_outcome: Callable[[RedetectOutcome], None] | None = None) -> list[RedetectOutcome]:
    """Every task on ``executor`` (``map_unordered``); the outcomes in the tasks' order."""
    by_mcap = {}
    for outcome in executor.map_unordered(redetect_one, tasks):
        by_mcap[outcome.mcap] = outcome
        if on_outcome is not None:
            on_outcome(outcome)
    return [by_mcap[t.mcap] for t in tasks]
