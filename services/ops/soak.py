"""A stack that runs all day: record a trial every ``every_s`` on a running :class:`Stack` and watch it.

:func:`run_soak` records ``trials`` simulated walks through the REST API, one every ``every_s`` (s), waits
for each one's results (:func:`gaitcap.services.ops.auto_trial.wait_for_results`) and meanwhile:

- counts every camera's frames on the bus (:class:`FrameGaps`): frame ids missing, the longest run of
  missing ids (s), the longest pause between two frames arriving (s);
- reads the resident memory of every process of the stack (with its own children) after each trial
  (:func:`rss_mb`), and the disk the data folder uses (:func:`disk_bytes`);
- checks every trial's recording is on disk (a recording is lost when its file is missing or empty), and
  at the end that no recording is orphaned (a trial folder with a recording the catalog does not know, or
  a trial left unfinished);
- with a fault ``plan`` (:func:`gaitcap.services.ops.fault_schedule.fault_plan`), injects each trial's
  fault at its moment and keeps what it did, the trial's final state and its reason (the error of a failed
  trial, the warnings of one done with warnings) and, while the worker is stopped, the read routes' times.

The result is a :class:`SoakReport` (``to_dict()``); ``bench/soak.py`` prints it.
"""

from __future__ import annotations

import contextlib
import logging
import os
import threading
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

log = logging.getLogger(__name__)


class FrameGaps:
    """Bus subscriber callback: per camera, frames seen, frame ids missing between them, the longest run of
    missing ids and the longest pause between arrivals (s)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.cameras: dict[str, dict] = {}

    def __call__(self, sample) -> None:
        from gaitcap.acquisition.encoding import parse_image_message
        from gaitcap.services.bus.messages import FrameMeta

        meta = FrameMeta.from_bytes(bytes(sample.attachment.to_bytes()))
        camera = parse_image_message(bytes(sample.payload.to_bytes())).camera
        self.see(camera, meta.frame_id, time.monotonic())

    def see(self, camera: str, frame_id: int, now_s: float) -> None:
        with self._lock:
            c = self.cameras.setdefault(camera, {"frames": 0, "missing_ids": 0, "longest_missing_run": 0,
                                                 "longest_pause_s": 0.0, "restarted_count": 0,
                                                 "last_id": None, "last_s": None})
            if c["last_id"] is not None:
                step = frame_id - c["last_id"]
                if step > 1:
                    c["missing_ids"] += step - 1
                    c["longest_missing_run"] = max(c["longest_missing_run"], step - 1)
                elif step < 1:
                    c["restarted_count"] += 1  # the counter went back: the camera started over
                c["longest_pause_s"] = max(c["longest_pause_s"], now_s - c["last_s"])
            c["frames"] += 1
            c["last_id"], c["last_s"] = frame_id, now_s

    def snapshot(self) -> dict[str, dict]:
        with self._lock:
            return {k: {n: v for n, v in c.items() if not n.startswith("last_")} for k, c in sorted(self.cameras.items())}


def _children_of() -> dict[int, list[int]]:
    out: dict[int, list[int]] = {}
    for f in Path("/proc").glob("[0-9]*/stat"):
        try:
            ppid = int(f.read_text().rsplit(")", 1)[1].split()[1])
        except (OSError, IndexError, ValueError):
            continue
        out.setdefault(ppid, []).append(int(f.parent.name))
    return out


def rss_mb(pid: int, children: dict[int, list[int]] | None = None) -> float:
    """Resident memory (MB, 10^6 bytes, as :func:`gaitcap.services.processing.worker.resident_mb`) of ``pid``
    and all its descendants (Linux ``/proc``; 0 for a process gone)."""
    children = _children_of() if children is None else children
    total_kb, todo = 0, [pid]
    while todo:
        p = todo.pop()
        todo += children.get(p, [])
        try:
            for line in Path(f"/proc/{p}/status").read_text().splitlines():
                if line.startswith("VmRSS:"):
                    total_kb += int(line.split()[1])
        except (OSError, ValueError):
            continue
    return total_kb * 1024 / 1e6  # VmRSS is in KiB


def disk_bytes(folder: Path) -> int:
    """Bytes of the files under ``folder`` (what the data folder uses)."""
    total = 0
    for root, _, files in os.walk(folder):
        for f in files:
            try:
                total += os.lstat(os.path.join(root, f)).st_size
            except OSError:
                continue
    return total


@dataclass(frozen=True)
class SoakTrial:
    """One trial of the soak: its id, end state, Stop -> preliminary / refined (s), whether its recording is
    on disk, the data folder's growth since the previous trial (bytes), and why the wait gave up ('' if not)."""

    trial_id: str
    state: str
    preliminary_s: float | None
    refined_s: float | None
    recording_kept: bool
    disk_growth_bytes: int
    gave_up: str = ""
    fault: str = ""
    fault_detail: str = ""
    reason: str = ""
    read_p99_s: float | None = None


@dataclass(frozen=True)
class SoakReport:
    """What :func:`run_soak` saw. ``rss_mb``: process -> [first, last, max] resident memory (MB);
    ``rss_series_mb``: process -> its resident memory before the first trial and after each (MB);
    ``cameras``: :class:`FrameGaps` per camera; ``restarts``: process -> restarts by the supervisor."""

    minutes: float
    trials: tuple[SoakTrial, ...]
    cameras: dict[str, dict]
    rss_mb: dict[str, list[float]]
    restarts: dict[str, int]
    disk_per_trial_mb: float
    frame_period_s: float
    rss_series_mb: dict[str, list[float]] = field(default_factory=dict)
    orphans: tuple[str, ...] = ()
    warm_up: int = 10
    trials_planned: int = 0
    rss_pids: dict[str, list[int]] = field(default_factory=dict)
    ended_early: str = ""  # why the day ended before its time (a trial that could not be started or followed)

    @property
    def all_done(self) -> bool:
        return bool(self.trials) and all(t.state in ("done", "done_with_warnings") for t in self.trials)

    @property
    def all_ended_with_reason(self) -> bool:
        """Every trial ended done, or failed / done with warnings saying why."""
        return bool(self.trials) and all(t.state == "done" or (t.state in ("done_with_warnings", "failed")
                                                               and t.reason) for t in self.trials)

    @property
    def rss_slope_mb_per_trial(self) -> dict[str, float]:
        """Per process, how fast its resident memory grows after ``warm_up`` trials (MB per trial): the
        least-squares slope over each life of the process (a restart starts a new one, ``rss_pids``) after
        the life's own first ``warm_up`` trials (a restarted process warms up again, as the stack's first one
        did): see :func:`life_slope`. One line through a restart's drop would read a growing process as
        flat."""
        return {name: life_slope(series, self.rss_pids.get(name, []), warm_up=self.warm_up)
                for name, series in self.rss_series_mb.items()}

    @property
    def rss_lives(self) -> dict[str, list[dict]]:
        """Per process, each life after its first ``warm_up`` trials (the lives that ended within them left
        out): its samples, first / last MB and slope."""
        return {name: [{"samples": len(v), "first_mb": v[0], "last_mb": v[-1], "slope_mb_per_trial": slope(v)}
                       for v in (life[self.warm_up:] for life in lives(series, self.rss_pids.get(name, []))) if v]
                for name, series in self.rss_series_mb.items()}

    @property
    def recordings_lost(self) -> int:
        return sum(not t.recording_kept for t in self.trials)

    @property
    def longest_camera_pause_s(self) -> float:
        return max((c["longest_pause_s"] for c in self.cameras.values()), default=float("inf"))

    @property
    def missing_frame_ids(self) -> int:
        return sum(c["missing_ids"] for c in self.cameras.values())

    def to_dict(self) -> dict:
        out = asdict(self)
        out.update(all_done=self.all_done, recordings_lost=self.recordings_lost,
                   longest_camera_pause_s=self.longest_camera_pause_s, missing_frame_ids=self.missing_frame_ids,
                   all_ended_with_reason=self.all_ended_with_reason, rss_slope_mb_per_trial=self.rss_slope_mb_per_trial,
                   rss_lives=self.rss_lives)
        return out


MIN_LIFE_SAMPLES = 20  # a life with fewer samples (after its warm-up) is not judged alone: the worker's memory
# scatters by 19-45 MB from trial to trial (the 120-minute day, docs/benchmarks.md), so the slope of 5 samples
# has a standard error of 6-14 MB a trial; of 20, 0.7-1.7
MIN_POOLED_SAMPLES = 3  # ... but pooled with the others (one slope for all, an intercept each) from this many


def lives(values: list[float], pids: list[int]) -> list[list[float]]:
    """``values`` cut where ``pids`` (the process id at each sample, same length) changes: one list per life
    of the process; the whole of ``values`` as one life where no ids were recorded."""
    if len(pids) != len(values) or not values:
        return [list(values)] if values else []
    out = [[values[0]]]
    for prev, pid, v in zip(pids, pids[1:], values[1:], strict=False):
        if pid != prev:
            out.append([])
        out[-1].append(v)
    return out


def life_slope(values: list[float], pids: list[int], *, warm_up: int = 0) -> float:
    """How fast ``values`` grow (units per step) over the lives of :func:`lives`, each without its first
    ``warm_up`` samples: the larger of the steepest least-squares slope of a life that keeps at least
    :data:`MIN_LIFE_SAMPLES` samples (one leaking life is not averaged away by flat ones) and the slope
    common to all the lives that keep at least :data:`MIN_POOLED_SAMPLES` (each with an intercept of its
    own: a restart's drop reads as neither growth nor fall; a short life counts by its length); the slope
    over ``values[warm_up:]`` where no life keeps that many."""
    kept = [life[warm_up:] for life in lives(values, pids) if len(life) - warm_up >= MIN_POOLED_SAMPLES]
    if not kept:
        return slope(values[warm_up:])
    return max([pooled_slope(kept), *(slope(v) for v in kept if len(v) >= MIN_LIFE_SAMPLES)])


def pooled_slope(parts: list[list[float]]) -> float:
    """The least-squares slope common to ``parts`` (units per step), each part with its own intercept (a part
    of fewer than 2 values adds nothing); 0.0 when none has 2."""
    num = den = 0.0
    for v in (p for p in parts if len(p) >= 2):
        mx, my = (len(v) - 1) / 2, sum(v) / len(v)
        num += sum((i - mx) * (y - my) for i, y in enumerate(v))
        den += sum((i - mx) ** 2 for i in range(len(v)))
    return num / den if den else 0.0


def slope(values: list[float]) -> float:
    """Least-squares slope of ``values`` over their index (units per step); 0.0 for fewer than 2."""
    return pooled_slope([values])


def _recording_kept(stack, trial_id: str) -> bool:
    from gaitcap.services import catalog as cat

    db = cat.open_catalog(stack.cfg.catalog, create=False)
    try:
        path = cat.get_trial(db, trial_id).recording_path
    finally:
        db.close()
    p = Path(path) if Path(path).is_absolute() else stack.data_dir / path
    return p.is_file() and p.stat().st_size > 0


def _sample_rss(stack, into: dict[str, list[float]], series: dict[str, list[float]],
                pids: dict[str, list[int]]) -> None:
    children = _children_of()
    for name in stack.supervisor.children:
        pid = stack.supervisor.pid(name)
        mb = round(rss_mb(pid, children), 1)
        first = into.setdefault(name, [mb, mb, mb])
        first[1], first[2] = mb, max(first[2], mb)
        series.setdefault(name, []).append(mb)
        pids.setdefault(name, []).append(pid)


def _orphans(stack) -> tuple[str, ...]:
    """Recordings the catalog does not know (a trial folder's MCAP without a trial row) and trials left
    unfinished (recording, stopping, interrupted, recovered, recorded or processing) at the end."""
    from gaitcap.services import catalog as cat

    db = cat.open_catalog(stack.cfg.catalog, create=False)
    try:
        trials = {t.id: t.state for t in cat.list_trials(db, limit=100_000)}
    finally:
        db.close()
    folders = Path(stack.data_dir, "trials")
    unknown = [f"{p.parent.name}: recording without a trial" for p in sorted(folders.glob("*/recording.mcap"))
               if p.parent.name not in trials]
    open_ = [f"{tid}: left {state}" for tid, state in trials.items()
             if state not in ("done", "done_with_warnings", "failed")]
    return tuple(unknown + open_)


def _reason(trial: dict) -> str:
    """Why the trial ended as it did: a failed one's error first, then its warnings."""
    return "; ".join(filter(None, [trial.get("error") or "", *(trial.get("warnings") or [])]))


def _p99(times: list[float]) -> float | None:
    if not times:
        return None
    ordered = sorted(times)
    return ordered[min(len(ordered) - 1, int(0.99 * len(ordered)))]


def _one_trial(stack, ctx, fault, outcome, *, subject_id: str, trial_s: float, stall_s: float):
    """Start, record ``trial_s`` (with the fault at its moment), Stop, wait: (trial id, trial, prelim, refined,
    why the wait gave up)."""
    from gaitcap.services.ops.auto_trial import WaitLimits, start_when_ready, wait_for_results
    from gaitcap.services.ops.fault_schedule import Moment

    def at(moment):
        if fault is not None and fault.moment is moment:
            outcome.at_s = round(time.monotonic() - t0, 2)
            fault.act(ctx, outcome)

    t0 = time.monotonic()
    with contextlib.ExitStack() as clients:
        ctx.client = clients.enter_context(stack.client())
        at(Moment.BEFORE_START)
        if fault is not None and fault.undo is not None:
            fault.undo(ctx)  # the fault was answered before Start; the trial itself goes ahead
        ctx.trial_id = trial_id = start_when_ready(ctx.client, {"subject_id": subject_id}, ready_timeout_s=120)
        t0 = time.monotonic()
        time.sleep(trial_s / 2)
        at(Moment.RECORDING)
        ctx.client = clients.enter_context(stack.client())  # signed in again (the API may have restarted)
        time.sleep(max(0.0, t0 + trial_s - time.monotonic()))
        if ctx.trial()["state"] == "recording":  # a killed recorder's trial is already interrupted
            r = ctx.client.post(f"/trials/{trial_id}/stop")
            if r.status_code == 503:  # no recorder answered: the trial is interrupted and its recording recovered
                log.warning("stop of %s: %s", trial_id, r.json().get("detail", "")[:300])
            elif r.status_code != 200:
                raise RuntimeError(f"stop of {trial_id} failed ({r.status_code}): {r.text[:300]}")
        stopped = time.monotonic()
        at(Moment.PROCESSING)
        trial, prelim, refined, why = wait_for_results(ctx.client, trial_id, limits=WaitLimits(stall_s=stall_s),
                                                       stopped_at=stopped)
    return trial_id, trial, prelim, refined, why


def run_soak(stack, *, trials: int, every_s: float = 60.0, trial_s: float = 20.0, stall_s: float = 600.0,
             subject_id: str = "SOAK001", plan: dict[int, str] | None = None, stop_s: float = 60.0,
             warm_up: int = 10, until_s: float | None = None) -> SoakReport:
    """Record ``trials`` walks of ``trial_s`` on the running ``stack``, one starting every ``every_s`` (or
    as soon as the previous one's results are in, when later), with the faults of ``plan`` (trial index ->
    fault name, :data:`gaitcap.services.ops.fault_schedule.FAULTS`; ``stop_s``: the worker's SIGSTOP), and
    report what happened; memory slopes leave out the first ``warm_up`` trials. ``until_s``: the day's
    length (s from the start); no trial starts after it, so a loaded machine runs fewer trials, not longer."""
    from gaitcap.services.ops.fault_schedule import FAULTS, FaultContext, FaultOutcome

    if trials < 1 or every_s <= 0 or trial_s <= 0:
        raise ValueError(f"soak: need trials >= 1, every_s > 0, trial_s > 0; got {trials}, {every_s}, {trial_s}")
    plan = plan or {}
    gaps, rss, series, pids, done, ended_early = FrameGaps(), {}, {}, {}, [], ""
    session = stack.bus_session()
    sub = session.declare_subscriber(stack.bus.keys.image(), gaps)
    restarts0 = {n: stack.supervisor.restarts(n) for n in stack.supervisor.children}
    ctx = FaultContext(stack, stop_s=stop_s)
    t0 = time.monotonic()
    try:
        _sample_rss(stack, rss, series, pids)
        disk = disk_bytes(stack.data_dir)
        for k in range(trials):
            time.sleep(max(0.0, t0 + k * every_s - time.monotonic()))
            if until_s is not None and time.monotonic() - t0 >= until_s:
                log.info("soak: the day's %.0f s are over after %d of %d trials", until_s, k, trials)
                break
            fault = FAULTS[plan[k]] if k in plan else None
            outcome = FaultOutcome(fault.name) if fault else None
            try:
                trial_id, trial, prelim, refined, why = _one_trial(stack, ctx, fault, outcome, subject_id=subject_id,
                                                                   trial_s=trial_s, stall_s=stall_s)
            except RuntimeError as exc:  # e.g. Start refused: the day ends here, and what it saw is reported
                ended_early = f"trial {k + 1}: {exc}"
                log.error("soak: the day ends early at %s", ended_early)
                break
            now_disk = disk_bytes(stack.data_dir)
            done.append(SoakTrial(trial_id, trial["state"], prelim, refined, _recording_kept(stack, trial_id),
                                  now_disk - disk, why, fault=outcome.fault if outcome else "",
                                  fault_detail=outcome.detail if outcome else "", reason=_reason(trial),
                                  read_p99_s=_p99(outcome.read_times_s) if outcome else None))
            disk = now_disk
            _sample_rss(stack, rss, series, pids)
            log.info("soak trial %d/%d %s%s: %s, preliminary %s s, refined %s s", k + 1, trials, trial_id,
                     f" ({outcome.fault}: {outcome.detail})" if outcome else "", trial["state"], prelim, refined)
    finally:
        sub.undeclare()
        session.close()
    growth = sorted(t.disk_growth_bytes for t in done)
    return SoakReport(minutes=(time.monotonic() - t0) / 60, trials=tuple(done), cameras=gaps.snapshot(), rss_mb=rss,
                      restarts={n: stack.supervisor.restarts(n) - restarts0[n] for n in restarts0},
                      disk_per_trial_mb=growth[len(growth) // 2] / 1e6 if growth else 0.0,
                      frame_period_s=1.0 / stack.cfg.fps, rss_series_mb=series, orphans=_orphans(stack),
                      warm_up=warm_up, trials_planned=trials,
                      rss_pids=pids, ended_early=ended_early)
