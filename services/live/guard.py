"""The API's trial guard: no trial stays ``recording`` when nobody records it, and a cut recording is
recovered and processed.

Every ``period_s`` (a thread of the API process) :meth:`TrialGuard.check` looks at the trials that hold
the recorder (``recording``, ``stopping``) or wait for a recovery (``interrupted``):

- ``recording``: the recorder's liveliness token is gone for more than ``down_s`` (process died), or the
  recorder answers that it records something else and it (re)started after the trial began (or the
  trial is older than ``start_grace_s``) -> ``interrupted``, with the reason.
- ``stopping`` for longer than ``stop_grace_s`` (the Stop request died with its API process) -> the
  finished file exists: ``recorded`` (processing queued); else ``interrupted``.
- ``interrupted``: the recorder finalises cut files when it restarts; once ``<recording>.mcap`` exists
  the trial becomes ``recovered`` (what the recovery kept and lost goes into its quality record,
  processing is queued). If the recorder is up and not writing the ``.part`` for ``recover_after_s``,
  the guard recovers it itself. No file at all after ``give_up_s`` -> ``failed``, naming the files.

Every change is a compare-and-set (:func:`gaitcap.services.catalog.set_state`), so several API
processes may run guards at once.
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from gaitcap.services import catalog as cat

log = logging.getLogger(__name__)
RECORDER = "recorder"


@dataclass(frozen=True)
class GuardTimes:
    """Seconds: how long the recorder may be gone before its trial is interrupted (``down_s``), how
    long a Start may take (``start_grace_s``), a Stop (``stop_grace_s``), how long a restarted recorder
    gets to recover a cut file itself (``recover_after_s``), and when an unrecoverable trial fails."""

    period_s: float = 0.5
    down_s: float = 1.0
    start_grace_s: float = 15.0
    stop_grace_s: float = 30.0
    recover_after_s: float = 5.0
    give_up_s: float = 120.0


class TrialGuard:
    def __init__(self, catalog: cat.Catalog, link, *, times: GuardTimes = GuardTimes(), room: str = "",
                 pending=lambda: set()) -> None:
        self.catalog, self.link, self.times = catalog, link, times
        self.pending = pending  # () -> ids of trials whose Stop waits for the catalog (pending_stops): left alone
        self.room = room  # the guard's own room: another room's trials are its recorder's business, not ours
        self.started = time.time()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="trial-guard", daemon=True)
        self._by_state = {"recording": self._recording, "stopping": self._stopping, "interrupted": self._interrupted}

    def start(self) -> TrialGuard:
        self._thread.start()
        return self

    def close(self) -> None:
        self._stop.set()
        self._thread.join(5)

    def _run(self) -> None:
        failing = False  # the traceback once per outage, not every period
        while not self._stop.wait(self.times.period_s):
            try:
                self.check()
                if failing:
                    log.info("trial guard: checks work again")
                failing = False
            except Exception as exc:  # a transient catalog or bus error: try again next period
                if failing:
                    log.debug("trial guard check failed again: %s", exc)
                else:
                    log.exception("trial guard check failed; trying every %.1f s", self.times.period_s)
                failing = True

    # ------------------------------------------------------------------ one pass
    def check(self, now: float | None = None) -> None:
        now = time.time() if now is None else now
        waiting = self.pending()
        trials = [t for t in cat.list_trials(self.catalog, limit=50, room=self.room)
                  if t.state in self._by_state and t.id not in waiting]
        if not trials:
            return
        node = self.link.nodes().get(RECORDER)
        status = self.link.recorder_status() if node is not None and node.alive else None
        for trial in trials:
            try:
                self._by_state[trial.state](trial, node, status, now)
            except cat.IllegalTransition as exc:  # another request or guard moved it first
                log.info("trial guard: %s", exc)

    def _recording(self, trial: cat.TrialInfo, node, status: dict | None, now: float) -> None:
        if node is None:  # never seen since this API started
            if now - self.started > self.times.start_grace_s:
                self._interrupt(trial, "no recorder is running (none seen on the bus since the API started)")
            return
        if not node.alive:
            if now - node.since > self.times.down_s:
                self._interrupt(trial, f"the recorder stopped at {_clock(node.since)} during the recording")
            return
        if status is None or status.get("trial_id") == trial.id:
            return
        restarted = node.seen_appearing and node.since > (trial.started_at or 0)
        if restarted:
            self._interrupt(trial, f"the recorder restarted at {_clock(node.since)} during the recording")
        elif now - (trial.started_at or now) > self.times.start_grace_s:
            self._interrupt(trial, "the recorder is not recording this trial (it recorded "
                                   f"{status.get('trial_id') or 'nothing'})")

    def _stopping(self, trial: cat.TrialInfo, node, status: dict | None, now: float) -> None:
        if now - trial.updated_at < self.times.stop_grace_s:
            return
        if Path(trial.recording_path).is_file():
            cat.set_state(self.catalog, trial.id, "recorded", expect="stopping", enqueue=True,
                          stopped_at=trial.updated_at, stage="waiting for a worker")
            log.warning("trial %s: its Stop did not finish, but the recording is complete; processing queued",
                        trial.id)
        else:
            self._interrupt(trial, "the Stop did not finish", expect="stopping")

    def _interrupt(self, trial: cat.TrialInfo, reason: str, *, expect: str = "recording") -> None:
        text = f"{reason}; the recording is kept and will be recovered"
        cat.set_state(self.catalog, trial.id, "interrupted", expect=expect, error=text, stopped_at=time.time(),
                      stage="recovering the recording")
        log.error("trial %s interrupted: %s", trial.id, reason)

    def _interrupted(self, trial: cat.TrialInfo, node, status: dict | None, now: float) -> None:
        final = Path(trial.recording_path)
        part = final.with_name(final.name + ".part")
        if final.is_file():
            self._recovered(trial, final)
        elif part.is_file():
            writing = status is not None and status.get("trial_id") == trial.id
            if node is not None and node.alive and not writing and now - node.since > self.times.recover_after_s:
                from gaitcap.acquisition.recording.recovery import finalise_cut

                report = finalise_cut(part)
                if report["error"] is None:
                    self._recovered(trial, final)
        elif now - trial.updated_at > self.times.give_up_s:
            cat.set_state(self.catalog, trial.id, "failed", expect="interrupted", stage="",
                          error=f"{trial.error}; but no recording was found ({final} and {part.name} are missing)")

    def _recovered(self, trial: cat.TrialInfo, final: Path) -> None:
        from gaitcap.acquisition.recording.reader import read_summary

        summary = read_summary(final)
        reason = trial.error.split("; the recording is kept")[0] or "the recording was cut"
        what = (f"{reason.capitalize()}; the recording was recovered up to its last complete chunk "
                "(about the last second before the cut is lost)") if summary.get("recovered") else reason.capitalize()
        cat.set_quality(self.catalog, trial.id, "recovery", {**summary, "warnings": [what]})
        cat.set_state(self.catalog, trial.id, "recovered", expect="interrupted", enqueue=True,
                      stage="waiting for a worker", progress=0.0, error="")
        log.warning("trial %s recovered from %s; processing queued", trial.id, final)


def _clock(t: float) -> str:
    return time.strftime("%H:%M:%S", time.localtime(t))
