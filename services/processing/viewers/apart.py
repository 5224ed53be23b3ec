"""The trial's .rrd written in a child process, so that what Rerun's library allocates goes back with it.

Rerun's native library allocates with its own allocator (mimalloc, linked into ``rerun_bindings``), which
keeps much of what it freed and which glibc's ``malloc_trim`` cannot reach: in one long-running process
every .rrd written left about 2 MB more resident memory, growing without bound (``bench/worker_memory.py``
and ``docs/benchmarks.md``, "Worker memory over many trials"). :func:`write_rrd_apart` writes each file
in a child (:func:`~gaitcap.services.processing.apart.call_apart`). The file and its contents are the same as
:func:`~gaitcap.services.processing.viewers.rerun_trial.write_trial_rrd` writes in the process; an error
in the child is raised here with its message.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from gaitcap.services.processing.apart import call_apart
from gaitcap.services.processing.viewers.rerun_trial import RerunSettings, write_trial_rrd
from gaitcap.services.processing.viewers.trial_view import TrialView


def write_rrd_apart(path: Path, view: TrialView, settings: RerunSettings = RerunSettings()) -> Path:
    """:func:`~gaitcap.services.processing.viewers.rerun_trial.write_trial_rrd` in a child process that
    exits afterwards; the path written. The child's error is raised here; a child that died without an
    answer is a RuntimeError with its exit code."""
    # the fit's continuous trajectory (a closure, which cannot be pickled) stays here: the file draws the samples
    view = replace(view, trajectory=replace(view.trajectory, trajectory=None))
    return call_apart(write_trial_rrd, Path(path), view, settings, what=f"{Path(path).name}: the .rrd writer")
