"""Bounding the compiled code a long-running worker holds.

JAX compiles a jitted function once per input shape and keeps every executable it compiled for the life
of the process. The fits' shapes follow the trial's length (frames, B-spline knots), so a clinic's worker,
where no two trials have the same number of frames, compiled a new set for every trial and kept them all:
about 7-12 more executables and 40-60 MB more resident memory per trial (``bench/worker_memory.py``).

:class:`CompiledCode` keeps the compiled code of at most ``keep_trials`` trials: after that many jobs it
drops every compiled executable and JAX's tracing caches (:func:`jax.clear_caches`), collects garbage and
hands freed heap back to the system (glibc ``malloc_trim``). The next trial compiles what it needs again;
executables that took longer than 0.5 s to compile come back from the worker's on-disk compilation cache
(``DATA_DIR/.jax-cache``). The results are the same numbers: only what is kept in memory changes.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import gc
import logging
import time
from dataclasses import dataclass

log = logging.getLogger(__name__)


def compiled_executables() -> int:
    """Compiled executables held by every live jitted function (the sum of their caches' sizes)."""
    total = 0
    for obj in gc.get_objects():
        if type(obj).__name__ == "PjitFunction":
            try:
                total += obj._cache_size()
            except Exception:  # noqa: BLE001  (an object of another kind with this name)
                continue
    return total


def release_compiled_code() -> float:
    """Drop JAX's compiled executables and tracing caches, collect garbage and trim the C heap; seconds spent."""
    import jax

    t0 = time.perf_counter()
    jax.clear_caches()
    gc.collect()
    trim_heap()
    return time.perf_counter() - t0


def trim_heap() -> None:
    """Return the C heap's free pages to the system (glibc; nothing elsewhere)."""
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name) if name else None
        if libc is not None and hasattr(libc, "malloc_trim"):
            libc.malloc_trim(0)
    except OSError:
        return


@dataclass(frozen=True)
class CompiledCodeLimit:
    """``keep_trials``: jobs whose compiled code a worker keeps before it drops it all (>= 1)."""

    keep_trials: int = 1

    def __post_init__(self) -> None:
        if self.keep_trials < 1:
            raise ValueError(f"keep_trials: keep the compiled code of >= 1 trial, got {self.keep_trials}")


class CompiledCode:
    """Counts the jobs since the compiled code was last dropped and drops it every ``keep_trials``."""

    def __init__(self, limit: CompiledCodeLimit = CompiledCodeLimit()) -> None:
        self.limit, self.jobs_held, self.releases = limit, 0, 0

    def after_job(self) -> bool:
        """Call after each job; True when the compiled code was dropped now."""
        self.jobs_held += 1
        if self.jobs_held < self.limit.keep_trials:
            return False
        seconds = release_compiled_code()
        self.jobs_held, self.releases = 0, self.releases + 1
        log.info("compiled code of the last %d job(s) dropped in %.2f s", self.limit.keep_trials, seconds)
        return True
