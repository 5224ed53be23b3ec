"""The trial state machine.

::

    recording -> [stopping ->] recorded -> processing -> done | done_with_warnings | failed
    recording | stopping -> interrupted -> recovered -> processing -> ...
    (any state but done*) -> failed

``stopping``: one Stop request won the compare-and-set and is asking the recorder to close the file
(concurrent Stops see ``stopping`` and change nothing). ``interrupted``: the recorder died or restarted
while writing the trial; its file is being recovered. ``recovered``: the complete chunks of the cut
recording were finalised into a readable MCAP (what was lost is in the trial's quality record); it is
processed like a recorded trial. ``done_with_warnings``: results exist but the data had serious
problems (the warnings say which). A failed or done trial may be re-queued (``-> recorded``) by an
operator or when the patient is chosen anew.

Every transition is one SQL ``UPDATE ... WHERE state IN (allowed sources)`` (see
:func:`gaitcap.services.catalog.trials.set_state`). Illegal transitions raise :class:`IllegalTransition`
(a ValueError) naming both states.
"""

from __future__ import annotations

from enum import StrEnum


class TrialState(StrEnum):
    RECORDING = "recording"
    STOPPING = "stopping"
    INTERRUPTED = "interrupted"
    RECOVERED = "recovered"
    RECORDED = "recorded"
    PROCESSING = "processing"
    DONE = "done"
    DONE_WITH_WARNINGS = "done_with_warnings"
    FAILED = "failed"


class IllegalTransition(ValueError):
    """A state change the state machine does not allow."""


S = TrialState
ALLOWED: dict[TrialState, frozenset[TrialState]] = {
    S.RECORDING: frozenset({S.STOPPING, S.RECORDED, S.INTERRUPTED, S.FAILED}),
    S.STOPPING: frozenset({S.RECORDED, S.INTERRUPTED, S.FAILED}),
    S.INTERRUPTED: frozenset({S.RECOVERED, S.FAILED}),
    S.RECOVERED: frozenset({S.PROCESSING, S.FAILED}),
    S.RECORDED: frozenset({S.PROCESSING, S.FAILED}),
    S.PROCESSING: frozenset({S.DONE, S.DONE_WITH_WARNINGS, S.FAILED}),
    S.DONE: frozenset({S.RECORDED}),
    S.DONE_WITH_WARNINGS: frozenset({S.RECORDED}),
    S.FAILED: frozenset({S.RECORDED}),
}
# States a worker takes a trial from (a queued processing job) and the finished ones.
PROCESSABLE = frozenset({S.RECORDED, S.RECOVERED})
FINISHED = frozenset({S.DONE, S.DONE_WITH_WARNINGS, S.FAILED})
# States that hold the recording slot (only one trial at a time).
HOLDS_SLOT = frozenset({S.RECORDING, S.STOPPING})


def sources_of(new: TrialState) -> frozenset[TrialState]:
    """The states from which ``new`` may be reached."""
    return frozenset(cur for cur, nxt in ALLOWED.items() if new in nxt)
