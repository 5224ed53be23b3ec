"""One trial driven through the REST API like the page does: start, wait, stop, wait for the metrics.

Used by ``gaitcap demo --auto`` and ``bench/turnaround.py``; times are measured from the moment Stop
returned to the moment the API serves the preliminary and the refined results.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

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


def run_trial(client: httpx.Client, *, subject_id: str, seconds: float, timeout_s: float = 120.0,
              poll_s: float = 0.1, session: str | None = None, ready_timeout_s: float = 30.0) -> TrialTimings:
    """Record ``seconds`` of walking and wait for the refined results (or failure / timeout)."""
    body = {"subject_id": subject_id, **({"session": session} if session else {})}
    trial_id = start_when_ready(client, body, ready_timeout_s=ready_timeout_s)
    t_start = time.monotonic()
    time.sleep(seconds)
    t_stop = time.monotonic()
    r = client.post(f"/trials/{trial_id}/stop")
    if r.status_code != 200:
        raise RuntimeError(f"stop failed ({r.status_code}): {r.text}")
    t_stopped = time.monotonic()
    prelim = refined = None
    trial = r.json()
    deadline = t_stopped + timeout_s
    while time.monotonic() < deadline:
        trial = client.get(f"/trials/{trial_id}").json()
        if prelim is None and "preliminary" in trial["results"]:
            prelim = time.monotonic() - t_stopped
        if "refined" in trial["results"]:
            refined = time.monotonic() - t_stopped
        if trial["state"] in FINISHED:
            break
        time.sleep(poll_s)
    return TrialTimings(trial_id, t_stop - t_start, t_stopped - t_stop, prelim, refined, trial["state"],
                        trial.get("error", ""), tuple(str(w) for w in trial.get("warnings") or ()))


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
