"""Starting and supervising a set of processes: logs to files, restart on crash, clean shutdown.

Each :class:`ProcessSpec` becomes one child process (its own process group) whose stdout and stderr go
to ``<log_dir>/<name>.log``. :meth:`Supervisor.poll` restarts a child that exited unexpectedly, forever,
with exponential back-off (:class:`Backoff`: a child that keeps crashing waits 0.5, 1, 2, ... up to 30 s
between restarts; one that ran ``stable_s`` without crashing starts over at 0.5 s). It never gives up:
each crash is logged as an error with the exit code and count, and :meth:`Supervisor.states` tells
which children run, which wait for a restart and since when. :meth:`Supervisor.stop` sends SIGTERM,
then SIGKILL after a grace period.
"""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Backoff:
    """Delay before restarting a crashed child: ``first_s * 2**(crashes in a row - 1)``, at most
    ``max_s``; a child that ran ``stable_s`` seconds counts as healthy again (crashes in a row reset)."""

    first_s: float = 0.5
    max_s: float = 30.0
    stable_s: float = 30.0

    def __post_init__(self) -> None:
        if not 0 < self.first_s <= self.max_s:
            raise ValueError(f"first_s/max_s: need 0 < first_s <= max_s, got {self.first_s}, {self.max_s}")
        if self.stable_s <= 0:
            raise ValueError(f"stable_s: must be > 0 s, got {self.stable_s}")

    def delay_s(self, crashes_in_a_row: int) -> float:
        return min(self.max_s, self.first_s * 2 ** max(0, crashes_in_a_row - 1))


@dataclass(frozen=True)
class ProcessSpec:
    """name: unique; argv: the command; ready_text: a line fragment the process logs once it is ready;
    nice: added to the process's nice value (lower CPU priority); backoff: restart delays."""

    name: str
    argv: tuple[str, ...]
    env: dict[str, str] = field(default_factory=dict)
    ready_text: str = ""
    nice: int = 0  # > 0: lower CPU priority than the other processes
    backoff: Backoff = Backoff()


@dataclass(frozen=True)
class ChildState:
    """What the supervisor knows of one child: ``running`` or ``waiting`` (crashed, restart due at
    ``restart_at``, UNIX s); restarts so far; crashes in a row; last exit code; since when (UNIX s)."""

    name: str
    state: str
    pid: int
    restarts: int
    crashes_in_a_row: int
    last_exit_code: int | None
    since: float
    restart_at: float | None


@dataclass
class _Child:
    spec: ProcessSpec
    proc: subprocess.Popen
    log_path: Path
    log_offset: int
    started: float = field(default_factory=time.monotonic)
    since: float = field(default_factory=time.time)
    restarts: int = 0
    crashes_in_a_row: int = 0
    last_exit_code: int | None = None
    restart_due: float | None = None  # monotonic s; set while waiting out the back-off


class Supervisor:
    def __init__(self, log_dir: Path, *, base_env: dict[str, str] | None = None) -> None:
        self.log_dir = Path(log_dir)
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self.base_env = dict(os.environ if base_env is None else base_env)
        self.children: dict[str, _Child] = {}
        self._lock = threading.RLock()  # poll() may run in a supervising thread

    def _spawn(self, spec: ProcessSpec) -> tuple[subprocess.Popen, Path, int]:
        path = self.log_dir / f"{spec.name}.log"
        offset = path.stat().st_size if path.exists() else 0
        out = open(path, "ab")  # noqa: SIM115  (kept open by the child)
        env = {**self.base_env, **spec.env, "PYTHONUNBUFFERED": "1"}
        proc = subprocess.Popen(spec.argv, stdout=out, stderr=subprocess.STDOUT, env=env,
                                stdin=subprocess.DEVNULL, start_new_session=True)
        if spec.nice:  # before the child starts its threads (they inherit it)
            try:
                os.setpriority(os.PRIO_PROCESS, proc.pid, os.getpriority(os.PRIO_PROCESS, 0) + spec.nice)
            except OSError:
                log.warning("could not lower the priority of %s", spec.name)
        out.close()
        log.info("started %s (pid %s)", spec.name, proc.pid)
        return proc, path, offset

    def start(self, spec: ProcessSpec) -> None:
        with self._lock:
            if spec.name in self.children:
                raise ValueError(f"process {spec.name} is already running")
            proc, path, offset = self._spawn(spec)
            self.children[spec.name] = _Child(spec, proc, path, offset)

    def pid(self, name: str) -> int:
        return self.children[name].proc.pid

    def restarts(self, name: str) -> int:
        """How often ``name`` was restarted after exiting."""
        return self.children[name].restarts

    def log_text(self, name: str) -> str:
        child = self.children[name]
        with open(child.log_path, "rb") as f:
            f.seek(child.log_offset)
            return f.read().decode(errors="replace")

    def wait_ready(self, name: str, timeout_s: float) -> None:
        """Wait until ``name`` logged its ready text; RuntimeError (with its log tail) if it died or timed out."""
        child = self.children[name]
        deadline = time.monotonic() + timeout_s
        while child.spec.ready_text not in self.log_text(name):
            if child.proc.poll() is not None:
                raise RuntimeError(f"{name} exited with code {child.proc.returncode}:\n{self.log_text(name)[-3000:]}")
            if time.monotonic() > deadline:
                raise RuntimeError(f"{name} not ready after {timeout_s:.0f} s:\n{self.log_text(name)[-3000:]}")
            time.sleep(0.1)

    def poll(self) -> list[str]:
        """Restart children that exited once their back-off has passed; returns the names restarted.

        Never raises for a crashing child: it is restarted again and again, later each time."""
        restarted = []
        now = time.monotonic()
        with self._lock:
            for name, child in self.children.items():
                if not self._exited(child, now):
                    continue
                if now >= child.restart_due:
                    child.proc, child.log_path, child.log_offset = self._spawn(child.spec)
                    child.started, child.since, child.restart_due = now, time.time(), None
                    child.restarts += 1
                    restarted.append(name)
        return restarted

    def _exited(self, child: _Child, now: float) -> bool:
        """Whether the child has exited (its crash recorded once, with its restart due, when first seen)."""
        if child.restart_due is None:
            code = child.proc.poll()
            if code is None:
                return False
            self._crashed(child, code, now)
        return True

    @staticmethod
    def _crashed(child: _Child, code: int, now: float) -> None:
        ran_s = now - child.started
        child.crashes_in_a_row = 1 if ran_s >= child.spec.backoff.stable_s else child.crashes_in_a_row + 1
        delay = child.spec.backoff.delay_s(child.crashes_in_a_row)
        child.last_exit_code, child.restart_due, child.since = code, now + delay, time.time()
        log.error("%s exited with code %s after %.1f s (%d crashes in a row); restarting in %.1f s; see %s",
                  child.spec.name, code, ran_s, child.crashes_in_a_row, delay, child.log_path)

    def states(self) -> list[ChildState]:
        """Every child's state now (for health reports)."""
        now_mono, now = time.monotonic(), time.time()
        with self._lock:
            return [ChildState(name, "waiting" if self._exited(c, now_mono) else "running",
                               c.proc.pid, c.restarts, c.crashes_in_a_row, c.last_exit_code, c.since,
                               None if c.restart_due is None else now + (c.restart_due - now_mono))
                    for name, c in self.children.items()]

    def kill(self, name: str, sig: int = signal.SIGKILL) -> None:
        """Send ``sig`` to one child's process group (fault injection, tests)."""
        os.killpg(self.children[name].proc.pid, sig)

    def restart(self, name: str) -> None:
        """Stop one child (SIGTERM, then SIGKILL) and start it again."""
        with self._lock:
            child = self.children.pop(name)
            _terminate([(name, child.proc)], grace_s=10)
            self.start(child.spec)

    def stop(self, *, grace_s: float = 10.0) -> None:
        """SIGTERM every child (reverse start order), SIGKILL what is left after ``grace_s``."""
        with self._lock:
            procs = [(n, c.proc) for n, c in reversed(list(self.children.items()))]
            _terminate(procs, grace_s=grace_s)
            self.children.clear()


def _terminate(procs: list[tuple[str, subprocess.Popen]], *, grace_s: float) -> None:
    for _, p in procs:
        if p.poll() is None:
            try:
                os.killpg(p.pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
    deadline = time.monotonic() + grace_s
    for name, p in procs:
        try:
            p.wait(max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            log.warning("%s (pid %s) did not stop in %.0f s; killing it", name, p.pid, grace_s)
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            p.wait(5)
