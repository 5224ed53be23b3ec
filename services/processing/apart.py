"""Work whose native memory a long-running worker must not keep, run in a child process that exits after it.

Two libraries the worker calls for every trial keep native memory Python cannot free:

- Rerun's (the .rrd file) allocates with its own allocator (mimalloc, linked into ``rerun_bindings``) out of
  glibc's ``malloc_trim``'s reach: about +2 MB per file in one process;
- OpenSim's inverse kinematics keeps about 1.5 kB per frame fitted (+0.9 MB per call on a 20 s, 600-frame
  walk; both stages of a trial are fitted), whatever Python collects afterwards.

Measured in ``docs/benchmarks.md`` ("Memory per process over many trials, and Rerun's share", "What the
recorder, detector, API and worker kept over the 120-minute day").
:func:`call_apart` runs a function in a child forked from a small server process (multiprocessing's
``forkserver``, started once per process, with those libraries and their callers already imported, never
itself doing the work), so the child starts in a fraction of a second and everything it allocated is returned
when it exits. The function's value is sent back (it must pickle), its exception is raised here, and what it
logged is logged here, under the same logger names.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import threading
from collections.abc import Callable
from typing import Any, TypeVar

T = TypeVar("T")

#: imported once by the server process the children are forked from, so that a child imports nothing: the
#: program's main module (which multiprocessing would import again in every child), Rerun, the .rrd writer
#: and the modules of what a TrialView holds (gait report, keypoints), the recording's reader (the images),
#: pandas, which Rerun imports on its first text column (1.5 s), and the kinematics with OpenSim (10-18 s on a
#: loaded machine); importing them starts no thread, so forking after it is safe
PRELOAD = ["__main__", "rerun", "pandas", "gaitcap.services.processing.viewers.rerun_trial",
           "gaitcap.reconstruction.gait", "gaitcap.reconstruction.keypoints", "gaitcap.acquisition.recording.reader",
           "gaitcap.services.kinematics.trial", "gaitcap.services.kinematics.opensim_engine"]
_lock = threading.Lock()
_context: multiprocessing.context.BaseContext | None = None


def _forkserver() -> multiprocessing.context.BaseContext:
    """multiprocessing's forkserver context, its server preloading :data:`PRELOAD` (once per process).
    A forkserver, not fork: the worker has JAX's and the bus's threads, which a fork must not copy."""
    global _context
    with _lock:
        if _context is None:
            ctx = multiprocessing.get_context("forkserver")
            ctx.set_forkserver_preload(PRELOAD)
            _context = ctx
        return _context


def start_apart_server() -> None:
    """Start the children's server now (a worker's warm-up), so that the first trial does not wait for it
    (5-30 s on a loaded 2-core machine: a fresh interpreter importing Rerun, pandas, OpenSim and the callers)."""
    from multiprocessing import forkserver

    _forkserver()
    forkserver.ensure_running()


class _Records(logging.Handler):
    """Keeps the child's log records, made picklable (message formatted, traceback as text)."""

    def __init__(self) -> None:
        super().__init__()
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        if record.exc_info:
            record.exc_text = logging.Formatter().formatException(record.exc_info)
        record.msg, record.args, record.exc_info = record.getMessage(), None, None
        self.records.append(record)


def _run_and_exit(conn, level: int, env: dict[str, str], fn: Callable[..., Any], args: tuple, kwargs: dict) -> None:
    """The child: run ``fn`` in the caller's environment variables (the server's are those of its start),
    send back ("value" | "error", result, log records), exit at once (its files are closed by then; what the
    libraries would tidy at exit is the memory going back anyway)."""
    os.environ.clear()
    os.environ.update(env)
    root = logging.getLogger()
    root.handlers[:] = [keep := _Records()]
    root.setLevel(level)
    try:
        answer = ("value", fn(*args, **kwargs))
    except BaseException as exc:  # noqa: BLE001  (handed to the parent, which raises it)
        answer = ("error", exc)
    try:
        conn.send((*answer, keep.records))
    except Exception as exc:  # noqa: BLE001  (a value or error that does not pickle)
        conn.send(("error", RuntimeError(f"{type(exc).__name__}: {exc}"), keep.records))
    finally:
        conn.close()
        os._exit(0)


def call_apart(fn: Callable[..., T], *args: Any, what: str, **kwargs: Any) -> T:
    """``fn(*args, **kwargs)`` in a child process that exits afterwards; its value. The child sees this
    process's environment variables; its exception is raised here and its log records are logged here; a child
    that died without an answer is a RuntimeError naming ``what`` it was doing and its exit code. ``fn``, its
    arguments and its value must pickle."""
    ctx = _forkserver()
    ours, theirs = ctx.Pipe(duplex=False)
    level = logging.getLogger().getEffectiveLevel()
    child = ctx.Process(target=_run_and_exit, args=(theirs, level, dict(os.environ), fn, args, kwargs), name=what)
    child.start()
    theirs.close()
    try:
        kind, value, records = ours.recv()
    except EOFError:
        child.join()
        raise RuntimeError(f"{what}: its process died (exit code {child.exitcode})") from None
    finally:
        ours.close()
    child.join()
    for record in records:
        logging.getLogger(record.name).handle(record)
    if kind == "error":
        raise value
    return value
