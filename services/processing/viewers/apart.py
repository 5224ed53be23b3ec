"""The trial's .rrd written in a child process, so that what Rerun's library allocates goes back with it.

Rerun's native library allocates with its own allocator (mimalloc, linked into ``rerun_bindings``), which
keeps much of what it freed and which glibc's ``malloc_trim`` cannot reach: in one long-running process
every .rrd written left about 2 MB more resident memory, growing without bound (``bench/worker_memory.py``
and ``docs/benchmarks.md``, "Worker memory over many trials"). :func:`write_rrd_apart` writes each file
in a child forked from a small server process (multiprocessing's ``forkserver``, started once, with Rerun
and the writer already imported, never itself writing a file), so the child starts in a fraction of a
second and everything it allocated is returned when it exits. The file and its contents are the same as
:func:`~gaitcap.services.processing.viewers.rerun_trial.write_trial_rrd` writes in the process; an error
in the child is raised here with its message.
"""

from __future__ import annotations

import multiprocessing
import os
import threading
from dataclasses import replace
from pathlib import Path

from gaitcap.services.processing.viewers.rerun_trial import RerunSettings, write_trial_rrd
from gaitcap.services.processing.viewers.trial_view import TrialView

#: imported once by the server process the children are forked from, so that a child imports nothing: the
#: program's main module (which multiprocessing would import again in every child), Rerun, the writer and
#: the modules of what a TrialView holds (gait report, keypoints), the recording's reader (the images) and
#: pandas, which Rerun imports on its first text column (1.5 s); importing them starts no thread, so forking
#: after it is safe
PRELOAD = ["__main__", "rerun", "pandas", "gaitcap.services.processing.viewers.rerun_trial",
           "gaitcap.reconstruction.gait", "gaitcap.reconstruction.keypoints", "gaitcap.acquisition.recording.reader"]
_lock = threading.Lock()
_context: multiprocessing.context.BaseContext | None = None


def _forkserver() -> multiprocessing.context.BaseContext:
    """multiprocessing's forkserver context, its server preloading the .rrd writer (once per process).
    A forkserver, not fork: the worker has JAX's and the bus's threads, which a fork must not copy."""
    global _context
    with _lock:
        if _context is None:
            ctx = multiprocessing.get_context("forkserver")
            ctx.set_forkserver_preload(PRELOAD)
            _context = ctx
        return _context


def start_writer_server() -> None:
    """Start the writers' server now (a worker's warm-up), so that the first trial's file does not wait for it
    (5-20 s on a loaded 2-core machine: a fresh interpreter importing Rerun, pandas and the writer)."""
    from multiprocessing import forkserver

    _forkserver()
    forkserver.ensure_running()


def _write_and_exit(conn, path: Path, view: TrialView, settings: RerunSettings) -> None:
    """The child: write the file, send back its path or the error, and exit at once (the file is flushed,
    closed and renamed by then; what Rerun would tidy at exit is the memory going back anyway)."""
    try:
        answer = ("written", write_trial_rrd(path, view, settings))
    except BaseException as exc:  # noqa: BLE001  (handed to the parent, which raises it)
        answer = ("error", exc)
    try:
        conn.send(answer)
    finally:
        conn.close()
        os._exit(0)


def write_rrd_apart(path: Path, view: TrialView, settings: RerunSettings = RerunSettings()) -> Path:
    """:func:`~gaitcap.services.processing.viewers.rerun_trial.write_trial_rrd` in a child process that
    exits afterwards; the path written. The child's error is raised here; a child that died without an
    answer is a RuntimeError with its exit code."""
    ctx = _forkserver()
    # the fit's continuous trajectory (a closure, which cannot be pickled) stays here: the file draws the samples
    view = replace(view, trajectory=replace(view.trajectory, trajectory=None))
    ours, theirs = ctx.Pipe(duplex=False)
    child = ctx.Process(target=_write_and_exit, args=(theirs, Path(path), view, settings), name="rrd-writer")
    child.start()
    theirs.close()
    try:
        kind, value = ours.recv()
    except EOFError:
        child.join()
        raise RuntimeError(f"{Path(path).name}: the .rrd writer process died (exit code {child.exitcode})") from None
    finally:
        ours.close()
    child.join()
    if kind == "error":
        raise value
    return value
