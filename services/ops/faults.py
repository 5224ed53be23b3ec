"""Fault drills on a running :class:`~gaitcap.services.ops.stack.Stack`, over its REST API, with real
processes killed by the supervisor (SIGKILL). Used by ``bench/faults.py`` and the stack fault tests.

Each drill returns a :class:`FaultResult`: was the recording kept (``lost``), did the trial end with its
warnings (``flagged``), did it come back through recovery (``recovered``), and how many seconds passed
until the API reported the fault (``detect_s``: the trial's state, ``/health`` or a refused Start).
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import httpx
from gaitcap.services.ops.auto_trial import FINISHED

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class FaultResult:
    """One drill: ``lost`` the recording (no readable file or a failed trial), ``flagged`` (the trial
    ended with warnings, or a broken rig was refused), ``recovered`` (the trial came back through
    recovery), ``detect_s`` (s until the API reported the fault; None when not applicable)."""

    fault: str
    trial_id: str | None
    state: str
    lost: bool
    flagged: bool
    recovered: bool
    detect_s: float | None
    detail: str = ""


class Drill:
    """A stack, a REST client with its token, and the waiting helpers the drills share."""

    def __init__(self, stack, *, timeout_s: float = 180.0) -> None:
        self.stack, self.timeout_s = stack, timeout_s
        self._open = contextlib.ExitStack()
        self.client = self._open.enter_context(stack.client())

    def close(self) -> None:
        self._open.close()

    def wait(self, predicate: Callable[[], object], what: str, timeout_s: float | None = None, poll_s: float = 0.1):
        deadline = time.monotonic() + (timeout_s or self.timeout_s)
        while time.monotonic() < deadline:
            try:
                value = predicate()
            except httpx.HTTPError:
                value = None
            if value:
                return value
            time.sleep(poll_s)
        try:
            health = {k: v["status"] for k, v in self.health().items() if not v["ok"]}
        except httpx.HTTPError as exc:
            health = f"no answer ({exc})"
        raise TimeoutError(f"timed out waiting for {what}; not ok: {health}; logs in {self.stack.supervisor.log_dir}")

    def trial(self, tid: str) -> dict:
        return self.client.get(f"/trials/{tid}").raise_for_status().json()

    def health(self) -> dict:
        return httpx.get(f"{self.stack.cfg.url}/health", timeout=10).json()["components"]

    def healthy(self, component: str) -> bool:
        return bool(self.health()[component]["ok"])

    def start(self, subject: str) -> str:
        self.wait(lambda: self.healthy("recorder") and self.healthy("cameras"), "recorder and cameras", 90)
        r = self.client.post("/trials", json={"subject_id": subject})
        if r.status_code != 201:
            raise RuntimeError(f"Start refused: {r.status_code} {r.text[:300]}")
        return r.json()["id"]

    def finished(self, tid: str) -> dict:
        return self.wait(lambda: (t := self.trial(tid))["state"] in FINISHED and t, f"trial {tid} to finish")

    def result(self, fault: str, tid: str, detect_s: float | None, *, saw_recovery: bool = False) -> FaultResult:
        t = self.finished(tid)
        kept = Path(self.stack.data_dir, "trials", tid, "recording.mcap").is_file()
        lost = t["state"] == "failed" or not kept
        return FaultResult(fault, tid, t["state"], lost, t["state"] == "done_with_warnings" and bool(t["warnings"]),
                           saw_recovery or any("recovered" in w for w in t["warnings"]), detect_s,
                           "; ".join(t["warnings"]) or t["error"])


def _time_until(drill: Drill, predicate, what: str, t0: float, timeout_s: float = 30.0) -> float:
    drill.wait(predicate, what, timeout_s, poll_s=0.05)
    return time.monotonic() - t0


def concurrent_stops(drill: Drill, n: int = 6) -> FaultResult:
    """``n`` Stop requests at once (two tabs, client retries): exactly one processed trial, one job."""
    tid = drill.start("P0901")
    time.sleep(5)

    with contextlib.ExitStack() as open_clients:
        # signed in first: the Stops then go out at once
        clients = [open_clients.enter_context(drill.stack.client()) for _ in range(n)]
        with concurrent.futures.ThreadPoolExecutor(n) as pool:
            codes = list(pool.map(lambda c: c.post(f"/trials/{tid}/stop").status_code, clients))
    res = drill.result("concurrent stops", tid, None)
    from gaitcap.services import catalog as cat

    db = cat.open_catalog(drill.stack.cfg.catalog)
    try:
        jobs = len(cat.jobs_for_trial(db, tid))
    finally:
        db.close()
    ok = codes == [200] * n and jobs == 1
    # not a data fault: "flagged" here means the requests were handled exactly once
    return FaultResult(res.fault, tid, res.state, res.lost or not ok, ok, False, None,
                       f"replies {sorted(codes)}, {jobs} processing job(s)")


def recorder_killed(drill: Drill) -> FaultResult:
    """SIGKILL the recorder mid-trial: the trial is interrupted, its file recovered, processed, flagged."""
    tid = drill.start("P0902")
    time.sleep(4)
    t0 = time.monotonic()
    drill.stack.supervisor.kill("recorder")
    detect = _time_until(drill, lambda: drill.trial(tid)["state"] != "recording", "the trial to leave recording", t0)
    saw = drill.wait(lambda: drill.trial(tid)["state"] in ("recovered", "processing", *FINISHED), "recovery", 60)
    return drill.result("recorder SIGKILL mid-trial", tid, detect, saw_recovery=bool(saw))


def _kill_cameras(drill: Drill) -> None:
    for node in drill.stack.cfg.camera_node_names():
        drill.stack.supervisor.kill(node)


def camera_killed(drill: Drill) -> FaultResult:
    """SIGKILL the camera nodes mid-trial (every simulated camera): /health says so; the supervisor restarts
    them and their frames resume within the trial, counters started again; the trial is kept and flagged."""
    tid = drill.start("P0903")
    time.sleep(4)
    t0 = time.monotonic()
    _kill_cameras(drill)
    detect = _time_until(drill, lambda: not drill.healthy("cameras"), "/health to report the cameras", t0)
    drill.wait(lambda: drill.healthy("cameras"), "the cameras to come back", 120)
    time.sleep(3)
    drill.client.post(f"/trials/{tid}/stop").raise_for_status()
    return drill.result("camera SIGKILL mid-trial", tid, detect)


def cameras_down_at_start(drill: Drill) -> FaultResult:
    """Every camera down: Start is refused with the reason (no trial), until the cameras are back."""
    drill.wait(lambda: drill.healthy("cameras"), "the cameras", 90)
    t0 = time.monotonic()
    _kill_cameras(drill)
    detect = _time_until(drill, lambda: not drill.healthy("cameras"), "/health to report the cameras", t0)
    r = drill.client.post("/trials", json={"subject_id": "P0904"})
    refused = r.status_code == 409 and "Start refused" in r.json().get("detail", "")
    drill.wait(lambda: drill.healthy("cameras"), "the cameras to come back", 120)
    return FaultResult("all cameras down at Start", None, "refused" if refused else f"HTTP {r.status_code}",
                       False, refused, False, detect, r.json().get("detail", "")[:300])


def repeated_crashes(drill: Drill, crashes: int = 4) -> FaultResult:
    """The recorder killed ``crashes`` times in a row: restarted every time, /health tells each time,
    and a trial afterwards records and is processed."""
    detects = []
    for _ in range(crashes):
        drill.wait(lambda: drill.healthy("recorder"), "the recorder", 120)
        t0 = time.monotonic()
        drill.stack.supervisor.kill("recorder")
        detects.append(_time_until(drill, lambda: not drill.healthy("recorder"), "/health to report the recorder", t0))
    tid = drill.start("P0905")
    time.sleep(5)
    drill.client.post(f"/trials/{tid}/stop").raise_for_status()
    res = drill.result(f"recorder crashed {crashes} times", tid, max(detects))
    restarted = drill.stack.supervisor.restarts("recorder")
    return FaultResult(res.fault, tid, res.state, res.lost, restarted >= crashes, False, max(detects),
                       f"supervisor restarted the recorder {restarted} times")


DRILLS: dict[str, Callable[[Drill], FaultResult]] = {
    "concurrent_stops": concurrent_stops,
    "recorder_killed": recorder_killed,
    "camera_killed": camera_killed,
    "cameras_down_at_start": cameras_down_at_start,
    "repeated_crashes": repeated_crashes,
}
