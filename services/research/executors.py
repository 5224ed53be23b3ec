"""Where batch tasks run: in this process, a local process pool, or a Ray cluster, behind one interface.

Each backend is a frozen config (:class:`Inline`, :class:`LocalPool`, :class:`RayCluster`) whose
``open()`` gives an :class:`Executor`: ``map_unordered(fn, items, resources=None)`` yields ``fn(item)``
as tasks finish. ``fn`` must be a picklable module-level function and must not raise for an item's own
problems (it reports them in its result); an exception out of ``map_unordered`` means the machinery
failed (a worker died more often than the retries allow).

Worker processes (pool and Ray) compute with one XLA thread each (:data:`WORKER_ENV`), so N workers use
N cores and every backend gives bit-identical numbers. A local pool worker that dies (OOM kill, segfault,
SIGKILL) breaks the pool: the pool is rebuilt and the unfinished tasks submitted again (at most
``max_retries`` times each). Ray retries a task whose worker died by itself (``max_retries``).
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import logging
import multiprocessing
import os
from collections import Counter
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from typing import Any, Protocol

log = logging.getLogger(__name__)

#: environment of every worker process (set before JAX is imported there).
WORKER_ENV = {
    "XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1",
    "OMP_NUM_THREADS": "1",
    "JAX_PLATFORMS": os.environ.get("JAX_PLATFORMS", ""),
}


@dataclass(frozen=True)
class TaskResources:
    """What one task asks of a cluster node: CPUs and GPUs (fractions allowed)."""

    num_cpus: float = 1.0
    num_gpus: float = 0.0


class Executor(Protocol):
    def map_unordered(self, fn: Callable[[Any], Any], items: Iterable[Any],
                      resources: Callable[[Any], TaskResources] | None = None) -> Iterator[Any]: ...

    def close(self) -> None: ...


def _init_worker() -> None:
    for key, value in WORKER_ENV.items():
        if value:
            os.environ[key] = value


# ---------------------------------------------------------------------------------------------- inline
@dataclass(frozen=True)
class Inline:
    """Run tasks one after the other in this process (debugging, tiny jobs)."""

    @contextlib.contextmanager
    def open(self) -> Iterator[Executor]:
        yield _InlineExecutor()


class _InlineExecutor:
    def map_unordered(self, fn, items, resources=None):
        for item in items:
            yield fn(item)

    def close(self) -> None:
        pass


# ---------------------------------------------------------------------------------------------- pool
@dataclass(frozen=True)
class LocalPool:
    """A pool of ``workers`` fresh (spawned) processes on this machine."""

    workers: int = 2
    max_retries: int = 2

    def __post_init__(self) -> None:
        if not 1 <= self.workers <= 256:
            raise ValueError(f"workers: need 1..256 worker processes, got {self.workers}")
        if self.max_retries < 0:
            raise ValueError(f"max_retries: must be >= 0, got {self.max_retries}")

    @contextlib.contextmanager
    def open(self) -> Iterator[Executor]:
        yield _PoolExecutor(self)


class _PoolExecutor:
    def __init__(self, cfg: LocalPool) -> None:
        self.cfg = cfg

    def _pool(self) -> cf.ProcessPoolExecutor:
        return cf.ProcessPoolExecutor(self.cfg.workers, mp_context=multiprocessing.get_context("spawn"),
                                      initializer=_init_worker)

    def map_unordered(self, fn, items, resources=None):
        pending = dict(enumerate(items))
        breaks: Counter[int] = Counter()
        while pending:
            with self._pool() as pool:
                futures = {pool.submit(fn, item): i for i, item in pending.items()}
                try:
                    for future in cf.as_completed(futures):
                        result = future.result()
                        del pending[futures[future]]
                        yield result
                except BrokenProcessPool:
                    breaks.update(pending.keys())
                    worst = max(breaks[i] for i in pending)
                    log.warning("a pool worker died; resubmitting %d unfinished task(s) (try %d of %d)",
                                len(pending), worst, self.cfg.max_retries)
                    if worst > self.cfg.max_retries:
                        raise RuntimeError(f"local pool: workers died {worst} times with {len(pending)} "
                                           "task(s) unfinished; giving up (run again to resume)") from None

    def close(self) -> None:
        pass


# ---------------------------------------------------------------------------------------------- ray
@dataclass(frozen=True)
class RayCluster:
    """Ray tasks. ``address``: ``auto`` (the cluster this host belongs to), ``ray://host:10001`` (Ray
    client) or ``local`` (start a private single-node instance with ``local_cpus`` CPUs). When Ray is
    already initialised in this process (tests), that instance is used. ``max_retries``: retries of a task
    whose worker died."""

    address: str = "auto"
    max_retries: int = 3
    local_cpus: int | None = None
    init_kwargs: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.max_retries < 0:
            raise ValueError(f"max_retries: must be >= 0, got {self.max_retries}")

    @contextlib.contextmanager
    def open(self) -> Iterator[Executor]:
        try:
            import ray
        except ImportError:
            raise ValueError("--ray: Ray is not installed (pip install 'gaitcap[cluster]')") from None
        started = False
        if not ray.is_initialized():
            kwargs = {"include_dashboard": False, "log_to_driver": False,
                      "runtime_env": {"env_vars": {k: v for k, v in WORKER_ENV.items() if v}}, **self.init_kwargs}
            if self.address == "local":
                ray.init(num_cpus=self.local_cpus, **kwargs)
            else:
                ray.init(address=self.address, **kwargs)
            started = True
        try:
            yield _RayExecutor(self)
        finally:
            if started:
                ray.shutdown()


class _RayExecutor:
    def __init__(self, cfg: RayCluster) -> None:
        import ray

        self.cfg, self.ray = cfg, ray

    def cluster_gpus(self) -> float:
        return float(self.ray.cluster_resources().get("GPU", 0.0))

    def map_unordered(self, fn, items, resources=None):
        ray = self.ray
        remote = ray.remote(fn)
        env = {"env_vars": {k: v for k, v in WORKER_ENV.items() if v}}
        refs = []
        for item in items:
            res = resources(item) if resources else TaskResources()
            refs.append(remote.options(num_cpus=res.num_cpus, num_gpus=res.num_gpus, runtime_env=env,
                                       max_retries=self.cfg.max_retries, retry_exceptions=False).remote(item))
        while refs:
            done, refs = ray.wait(refs, num_returns=1)
            yield ray.get(done[0])

    def close(self) -> None:
        pass
