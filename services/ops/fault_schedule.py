"""A working day with faults: a fixed, seeded schedule of faults injected into a soak's trials.

:func:`fault_plan` deals the faults of :data:`FAULTS` over a soak's trials: after ``warm_up`` trials, one
fault every ``gap`` trials (each gap drawn from ``min_gap..max_gap`` by a seeded generator, so the same
seed gives the same day), the kinds taken in a seeded order, every kind once before any twice.

Each :class:`Fault` acts at one moment of its trial (a :class:`Moment`): before Start, mid-recording or
after Stop while the worker processes it, and may be undone after the trial. The faults:

- ``kill_detector``, ``kill_recorder``, ``kill_camera``: SIGKILL mid-recording (the supervisor restarts
  the process; a killed recorder's trial is interrupted, its file recovered and processed, flagged);
- ``kill_worker``: SIGKILL while it processes the trial (the restarted worker takes the job again once its
  lease has expired);
- ``stop_worker``: SIGSTOP of the worker while it processes the trial, for ``stop_s`` (60 s in the working
  day), then SIGCONT; meanwhile the read routes are timed (what the page does while a worker hangs);
- ``fill_disk``: the data folder's disk filled to the API's free-space threshold (a ballast file; the API
  runs with a threshold just under the disk's free space, ``GAITCAP_MIN_FREE_MB``, so the day never fills
  a real disk): Start is refused naming the disk, then the ballast goes and the trial is started again;
- ``restart_api``: the API restarted (SIGTERM, started again) mid-recording; Stop goes to the new one.

What happened is kept per trial in a :class:`FaultOutcome` (:mod:`gaitcap.services.ops.soak` runs them).
"""

from __future__ import annotations

import enum
import logging
import os
import random
import shutil
import signal
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

log = logging.getLogger(__name__)
READ_ROUTES = ("/trials", "/trials/{trial_id}", "/trials/{trial_id}/gait", "/patients", "/health")  # timed while stopped
DISK_MARGIN_MB = 256  # the API's threshold is this far below the disk's free space; the ballast fills twice it


class Moment(enum.Enum):
    BEFORE_START = "before Start"
    RECORDING = "mid-recording"
    PROCESSING = "while processing"


@dataclass
class FaultOutcome:
    """What one fault did: when (s after its trial's Start), what the API said (``detail``: a refusal's reason,
    a wait's), the read routes' answer times while it lasted (s), and whether it could be made at all."""

    fault: str
    at_s: float | None = None
    detail: str = ""
    read_times_s: list[float] = field(default_factory=list)
    made: bool = True


@dataclass(frozen=True)
class Fault:
    """One kind of fault: ``act(ctx, outcome)`` at ``moment``; ``undo(ctx)`` after the trial (or None)."""

    name: str
    moment: Moment
    act: Callable[[FaultContext, FaultOutcome], None]
    undo: Callable[[FaultContext], None] | None = None


class FaultContext:
    """The running stack, the trial under way (its id, None before Start), the REST client in use and the
    fault's settings: ``stop_s`` (the worker's SIGSTOP, s)."""

    def __init__(self, stack, *, stop_s: float = 60.0, wait_s: float = 300.0) -> None:
        self.stack, self.stop_s, self.wait_s = stack, stop_s, wait_s
        self.trial_id: str | None = None
        self.client = None
        self.ballast: Path | None = None

    def trial(self) -> dict:
        return self.client.get(f"/trials/{self.trial_id}").json()

    def wait_for(self, predicate: Callable[[], object], what: str, timeout_s: float | None = None) -> object:
        deadline = time.monotonic() + (timeout_s or self.wait_s)
        while time.monotonic() < deadline:
            try:
                if value := predicate():
                    return value
            except Exception:  # noqa: BLE001  (the API restarting, a process coming back)
                pass
            time.sleep(0.2)
        raise TimeoutError(f"fault schedule: timed out waiting for {what}")

    def worker(self) -> str:
        return self.stack.cfg.worker_names()[0]


def _kill(name_of: Callable[[FaultContext], list[str]]) -> Callable[[FaultContext, FaultOutcome], None]:
    def act(ctx: FaultContext, outcome: FaultOutcome) -> None:
        for name in name_of(ctx):
            ctx.stack.supervisor.kill(name)
        outcome.detail = f"SIGKILL {', '.join(name_of(ctx))}"
    return act


def _processing(ctx: FaultContext) -> None:
    ctx.wait_for(lambda: ctx.trial()["state"] in ("processing", "done", "done_with_warnings", "failed"),
                 f"trial {ctx.trial_id} to be processed")


def _kill_worker(ctx: FaultContext, outcome: FaultOutcome) -> None:
    _processing(ctx)
    _kill(lambda c: [c.worker()])(ctx, outcome)


def _time_reads(ctx: FaultContext, seconds: float) -> list[float]:
    """Read routes, in turn, for ``seconds``: each one's answer time (s; an answer, also a 404 of results not
    there yet, counts; a server error or none within 10 s: inf)."""
    times, end = [], time.monotonic() + seconds
    paths = [p.replace("{trial_id}", ctx.trial_id or "") for p in READ_ROUTES]
    while time.monotonic() < end:
        for path in paths:
            t0 = time.monotonic()
            try:
                answered = ctx.client.get(path, timeout=10).status_code < 500
            except Exception:  # noqa: BLE001  (counted as never answered)
                answered = False
            times.append(time.monotonic() - t0 if answered else float("inf"))
        time.sleep(0.2)
    return times


def _stop_worker(ctx: FaultContext, outcome: FaultOutcome) -> None:
    _processing(ctx)
    name = ctx.worker()
    ctx.stack.supervisor.kill(name, signal.SIGSTOP)
    try:
        outcome.read_times_s = _time_reads(ctx, ctx.stop_s)
    finally:
        ctx.stack.supervisor.kill(name, signal.SIGCONT)
    outcome.detail = f"SIGSTOP {name} for {ctx.stop_s:.0f} s"


def _fill_disk(ctx: FaultContext, outcome: FaultOutcome) -> None:
    """Ballast until the disk's free space is below the API's threshold; Start must be refused for it."""
    data = ctx.stack.data_dir
    threshold_mb = float(ctx.stack.cfg.extra_env.get("GAITCAP_MIN_FREE_MB", "0") or 0)
    if threshold_mb <= 0:
        outcome.made, outcome.detail = False, "the stack runs without GAITCAP_MIN_FREE_MB: no threshold to fill to"
        return
    free_mb = shutil.disk_usage(data).free / 2**20
    ballast_mb = max(0.0, free_mb - threshold_mb) + DISK_MARGIN_MB
    ctx.ballast = data / "ballast.fill"
    with open(ctx.ballast, "wb") as f:
        os.posix_fallocate(f.fileno(), 0, int(ballast_mb * 2**20))
    r = ctx.client.post("/trials", json={"subject_id": "SOAKDISK"})
    outcome.detail = f"{ballast_mb:.0f} MB ballast: Start answered {r.status_code} {r.json().get('detail', '')}"[:500]
    if r.status_code == 201:  # not refused: the trial would fill the disk; stop it at once
        ctx.client.post(f"/trials/{r.json()['id']}/stop")
        outcome.detail = "NOT REFUSED: " + outcome.detail


def disk_threshold_env(data_dir: Path, *, headroom_mb: float = 2048.0) -> dict[str, str]:
    """The API's environment for a stack whose disk the ``fill_disk`` fault fills: a free-space threshold
    ``headroom_mb`` below the disk's free space now (its trials never reach it; the ballast does)."""
    Path(data_dir).mkdir(parents=True, exist_ok=True)
    free_mb = shutil.disk_usage(data_dir).free / 2**20
    return {"GAITCAP_MIN_FREE_MB": f"{max(1.0, free_mb - headroom_mb):.0f}"}


def _free_disk(ctx: FaultContext) -> None:
    if ctx.ballast is not None:
        ctx.ballast.unlink(missing_ok=True)
        ctx.ballast = None


def _restart_api(ctx: FaultContext, outcome: FaultOutcome) -> None:
    ctx.stack.supervisor.restart("api")
    ctx.stack.supervisor.wait_ready("api", 120)
    outcome.detail = "API restarted (SIGTERM, started again)"


FAULTS: dict[str, Fault] = {f.name: f for f in (
    Fault("kill_detector", Moment.RECORDING, _kill(lambda c: ["detector"])),
    Fault("kill_recorder", Moment.RECORDING, _kill(lambda c: ["recorder"])),
    Fault("kill_camera", Moment.RECORDING, _kill(lambda c: c.stack.cfg.camera_node_names()[:1])),
    Fault("kill_worker", Moment.PROCESSING, _kill_worker),
    Fault("stop_worker", Moment.PROCESSING, _stop_worker),
    Fault("fill_disk", Moment.BEFORE_START, _fill_disk, _free_disk),
    Fault("restart_api", Moment.RECORDING, _restart_api),
)}


def fault_plan(trials: int, *, seed: int = 0, warm_up: int = 10, min_gap: int = 5, max_gap: int = 10,
               kinds: tuple[str, ...] = tuple(FAULTS)) -> dict[int, str]:
    """Trial index (0-based) -> the fault injected into it: the first after ``warm_up`` trials, then one
    every ``min_gap..max_gap`` trials (seeded), kinds in a seeded order, each once before any twice."""
    if min_gap < 1 or max_gap < min_gap:
        raise ValueError(f"fault gaps: need 1 <= min_gap <= max_gap, got {min_gap}, {max_gap}")
    unknown = [k for k in kinds if k not in FAULTS]
    if unknown or not kinds:
        raise ValueError(f"faults: unknown {unknown}; known: {sorted(FAULTS)}")
    rng = random.Random(seed)
    plan, k, order = {}, warm_up, []
    while k < trials:
        if not order:
            order = rng.sample(list(kinds), len(kinds))
        plan[k] = order.pop(0)
        k += rng.randint(min_gap, max_gap)
    return plan
