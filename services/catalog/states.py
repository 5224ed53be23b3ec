"""The trial state machine: recording -> recorded -> processing -> done | failed.

A trial may also fail from ``recording`` (the recorder died) or ``recorded`` (the job could not be
queued), and a failed trial may be re-queued for processing (``failed -> recorded``) by an operator, and so may a done trial whose patient was
chosen anew (``done -> recorded``).
Illegal transitions raise :class:`IllegalTransition` (a ValueError) naming both states.
"""

from __future__ import annotations

from enum import StrEnum


class TrialState(StrEnum):
    RECORDING = "recording"
    RECORDED = "recorded"
    PROCESSING = "processing"
    DONE = "done"
    FAILED = "failed"


class IllegalTransition(ValueError):
    """A state change the state machine does not allow."""


ALLOWED: dict[TrialState, frozenset[TrialState]] = {
    TrialState.RECORDING: frozenset({TrialState.RECORDED, TrialState.FAILED}),
    TrialState.RECORDED: frozenset({TrialState.PROCESSING, TrialState.FAILED}),
    TrialState.PROCESSING: frozenset({TrialState.DONE, TrialState.FAILED}),
    TrialState.DONE: frozenset({TrialState.RECORDED}),
    TrialState.FAILED: frozenset({TrialState.RECORDED}),
}


def check_transition(trial_id: str, current: str, new: str) -> TrialState:
    """Return ``new`` as a TrialState if ``current -> new`` is allowed, else raise IllegalTransition."""
    try:
        cur, nxt = TrialState(current), TrialState(new)
    except ValueError as exc:
        raise IllegalTransition(f"trial {trial_id}: unknown state in {current!r} -> {new!r}") from exc
    if nxt not in ALLOWED[cur]:
        raise IllegalTransition(f"trial {trial_id}: cannot go from {cur.value} to {nxt.value}")
    return nxt
