"""Starting and supervising a set of processes: logs to files, restart on crash, clean shutdown.

Each :class:`ProcessSpec` becomes one child process (its own process group) whose stdout and stderr go
to ``<log_dir>/<name>.log``. :meth:`Supervisor.poll` restarts a child that exited unexpectedly (up to
``max_restarts`` times); :meth:`Supervisor.stop` sends SIGTERM, then SIGKILL after a grace period.
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
class ProcessSpec:
    """name: unique; argv: the command; ready_text: a line fragment the process logs once it is ready;
    nice: added to the process's nice value (lower CPU priority)."""

    name: str
    argv: tuple[str, ...]
    env: dict[str, str] = field(default_factory=dict)
    ready_text: str = ""
    max_restarts: int = 3
    nice: int = 0  # > 0: lower CPU priority than the other processes


@dataclass
class _Child:
    spec: ProcessSpec
    proc: subprocess.Popen
    log_path: Path
    log_offset: int
    restarts: int = 0


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
        """Restart children that exited; returns the names restarted. Raises if one exhausted its restarts."""
        restarted = []
        with self._lock:
            for name, child in self.children.items():
                code = child.proc.poll()
                if code is None:
                    continue
                if child.restarts >= child.spec.max_restarts:
                    raise RuntimeError(f"{name} keeps exiting (code {code}); see {child.log_path}")
                log.warning("%s exited with code %s; restarting", name, code)
                child.proc, child.log_path, child.log_offset = self._spawn(child.spec)
                child.restarts += 1
                restarted.append(name)
        return restarted

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
