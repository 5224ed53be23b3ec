"""One trial driven through the REST API like the page does: start, wait, stop, wait for the metrics.

Used by ``gaitcap demo --auto`` and ``bench/turnaround.py``; times are measured from the moment Stop
returned to the moment the API serves the preliminary and the refined results.

After Stop, :func:`wait_for_results` follows the stages the worker reports (the trial's ``stage`` and
``progress``): a slow machine gives a slower result, not a failure. It gives up only when the worker has
reported nothing new for ``WaitLimits.stall_s`` or after ``WaitLimits.overall_s`` in all, and then says
what was still running and for how long (:class:`StageLog`), never an empty reason.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, field

import httpx

# the finished states (gaitcap.services.catalog.states.FINISHED), as the REST API spells them
FINISHED = ("done", "done_with_warnings", "failed")


@dataclass(frozen=True)
class TrialTimings:
    """trial_id; record_s: how long it recorded; preliminary_s / refined_s: Stop -> results served (s)."""

    trial_id: str
    record_s: float
    stop_call_s: float
    preliminary_s: float | None
    refined_s: float | None
    state: str
    error: str
    warnings: tuple[str, ...] = ()


def start_when_ready(client: httpx.Client, body: dict, *, ready_timeout_s: float = 30.0) -> str:
    """POST /trials, retried while the API refuses with 409 (the rig not ready yet: cameras still starting
    or below the frame-rate criteria) for up to ``ready_timeout_s``; returns the trial id. Raises
    RuntimeError with the API's last reason when the rig never becomes ready (the check is never
    overridden here: a clinician confirms that on the page)."""
    deadline = time.monotonic() + ready_timeout_s
    while True:
        r = client.post("/trials", json=body)
        if r.status_code == 201:
            return r.json()["id"]
        if r.status_code != 409 or time.monotonic() > deadline:
            raise RuntimeError(f"start failed ({r.status_code}): {r.text}")
        time.sleep(1.0)


@dataclass(frozen=True)
class WaitLimits:
    """How long to wait for a trial's results after Stop (s): give up when the worker has reported no new
    stage or progress for ``stall_s``, or after ``overall_s`` in all (generous: a busy machine is slow)."""

    stall_s: float = 600.0
    overall_s: float = 3600.0
    poll_s: float = 0.2

    def __post_init__(self) -> None:
        if not 0 < self.poll_s <= self.stall_s <= self.overall_s:
            raise ValueError(f"wait limits: need 0 < poll_s <= stall_s <= overall_s, got {self.poll_s}, "
                             f"{self.stall_s}, {self.overall_s}")


@dataclass
class StageLog:
    """What the worker reported, as seen by polling: each (state, stage) in turn with when it was first
    seen and the last progress change (monotonic s)."""

    t0: float
    stages: list[tuple[str, str, float]] = field(default_factory=list)  # (state, stage, first seen)
    progress: float = -1.0
    last_change: float = 0.0

    def see(self, trial: dict, now: float) -> None:
        key = (trial["state"], trial.get("stage", ""))
        if not self.stages or self.stages[-1][:2] != key:
            self.stages.append((*key, now))
            self.last_change = now
        if trial.get("progress", 0.0) != self.progress:
            self.progress, self.last_change = float(trial.get("progress", 0.0)), now

    def describe(self, now: float) -> str:
        """E.g. ``still processing, stage 'kinematics' (40 %) for 95 s; before: 'preliminary' 26 s``."""
        if not self.stages:
            return "the trial was never read back from the API"
        state, stage, since = self.stages[-1]
        where = f"stage {stage!r}" if stage else "no stage reported yet (queued for a worker?)"
        text = (f"still {state}, {where} ({max(self.progress, 0.0):.0%}) for {now - since:.0f} s, "
                f"nothing new reported for {now - self.last_change:.0f} s, {now - self.t0:.0f} s after Stop")
        done = [f"{(st or s)!r} {nxt - t:.0f} s" for (s, st, t), (_, _, nxt) in itertools.pairwise(self.stages)]
        return text + (f"; before: {', '.join(done)}" if done else "")


def record(client: httpx.Client, *, subject_id: str, seconds: float, session: str | None = None,
           ready_timeout_s: float = 30.0) -> tuple[str, float, float, dict]:
    """Start a trial, record ``seconds``, Stop: (trial id, record s, Stop call s, the trial after Stop)."""
    body = {"subject_id": subject_id, **({"session": session} if session else {})}
    trial_id = start_when_ready(client, body, ready_timeout_s=ready_timeout_s)
    t_start = time.monotonic()
    time.sleep(seconds)
    t_stop = time.monotonic()
    r = client.post(f"/trials/{trial_id}/stop")
    if r.status_code != 200:
        raise RuntimeError(f"stop failed ({r.status_code}): {r.text}")
    return trial_id, t_stop - t_start, time.monotonic() - t_stop, r.json()


def wait_for_results(client: httpx.Client, trial_id: str, *, limits: WaitLimits = WaitLimits(),
                     stopped_at: float | None = None) -> tuple[dict, float | None, float | None, str]:
    """Poll the trial until it is finished or the limits run out: (the trial, preliminary s, refined s
    after ``stopped_at`` (monotonic; default now), why it gave up: '' when finished)."""
    t0 = time.monotonic() if stopped_at is None else stopped_at
    seen, prelim, refined = StageLog(t0, last_change=t0), None, None
    while True:
        trial = client.get(f"/trials/{trial_id}").json()
        now = time.monotonic()
        seen.see(trial, now)
        if prelim is None and "preliminary" in trial["results"]:
            prelim = now - t0
        if refined is None and "refined" in trial["results"]:
            refined = now - t0
        if trial["state"] in FINISHED:
            return trial, prelim, refined, ""
        if now - seen.last_change > limits.stall_s:
            return trial, prelim, refined, f"gave up: {seen.describe(now)} (limit {limits.stall_s:.0f} s without news)"
        if now - t0 > limits.overall_s:
            return trial, prelim, refined, f"gave up: {seen.describe(now)} (limit {limits.overall_s:.0f} s in all)"
        time.sleep(limits.poll_s)


def run_trial(client: httpx.Client, *, subject_id: str, seconds: float, limits: WaitLimits = WaitLimits(),
              session: str | None = None, ready_timeout_s: float = 30.0) -> TrialTimings:
    """Record ``seconds`` of walking and wait for the refined results (or failure, or the limits). A trial
    not finished has ``error`` saying what was still running and for how long; a failed one without a
    reason says so."""
    trial_id, record_s, stop_call_s, _ = record(client, subject_id=subject_id, seconds=seconds, session=session,
                                                ready_timeout_s=ready_timeout_s)
    trial, prelim, refined, gave_up = wait_for_results(client, trial_id, limits=limits)
    error = gave_up or trial.get("error", "") or (
        "failed; the worker recorded no reason (see its log)" if trial["state"] == "failed" else "")
    return TrialTimings(trial_id, record_s, stop_call_s, prelim, refined, trial["state"], error,
                        tuple(str(w) for w in trial.get("warnings") or ()))


def format_metrics(gait: dict) -> str:
    """The gait summary as aligned text lines."""
    lines = [f"{gait['stage']} results ({gait['method']}), {len(gait['steps'])} steps:"]
    for name, m in gait["summary"].items():
        if m.get("mean") is None:
            continue
        sd = f" +- {m['sd']:.1f}" if m.get("sd") is not None else ""
        value = f"{m['mean']:9.0f}" if float(m["mean"]).is_integer() and not m.get("unit") else f"{m['mean']:9.2f}"
        lines.append(f"  {name:30s} {value}{sd} {m.get('unit', '')}".rstrip())
    return "\n".join(lines)
