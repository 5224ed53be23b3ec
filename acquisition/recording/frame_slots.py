"""One frame grid for a recording whose cameras may have restarted: frame ids as slots, restarts by time.

The cameras' frame ids count from one synchronised start (FLIR and simulated drivers), so a frame id is a
frame set. A camera (or the camera node) that restarts within a trial starts its counter again; its new
frame ids repeat ids already recorded, with later timestamps. Such a recording must not be refused (a
recording is never lost) nor read with the ids as they are (frames of two moments in one set). Here each
camera's frames, in time order, are cut into *segments* wherever the frame id goes back (an id repeated with a
later stamp is a duplicate, dropped and counted, not a restart), and every later segment is placed on the
reference grid by its timestamps (camera clocks are PTP-synchronised, and survive a restart):

    slot = frame_id + offset,   offset = median(round((timestamp_ns - anchor_ns) / period_ns) - frame_id)

with ``period_ns`` the median frame period and ``anchor_ns`` the timestamp of frame id 0 on the grid (the
median over the cameras' first segments). A camera's first segment keeps its ids, so a recording without
restarts reads exactly as before (a clock offset between cameras stays for the sync check to see). Frames that land on a slot the camera already has are dropped and counted.

A frame id far outside the recording (a corrupt message, or one written before the recorder checked frame
ids) is left out and counted (``strays``), never allocated for, in two steps. Before placing: a few frames
whose id is more than ``SLACK_FRAMES`` out of line with the frames around them in time, amid one counter
(:func:`_in_line`; a restart is a lasting jump, not a few frames), and a few frames at either end of a
camera's series whose timestamp is more than ``SLACK_FRAMES`` periods from the camera's other frames
while their id is not (a timestamp far off: without this, one frame stamped early would read as the
camera's first counter and the rest as a restart). After placing, so frames after a restart
(placed by time) are judged like any other: the frame sets of all cameras together are cut at their widest
gaps, keeping the side with more frames, until the recording spans at most ``2 x its frame sets +
SLACK_FRAMES`` (:func:`recording_span`; the memory a reader allocates stays bounded by the data); those
outside are left out and the rest placed again (a stray id would otherwise read as a counter restart).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

log = logging.getLogger(__name__)

DEFAULT_PERIOD_NS = 1_000_000_000 // 30
_SHORT_RUN = 3  # frames in line (in time) fewer than this, amid one counter, are stray frame ids
_PASSES = 3  # placements at most: the frames far outside are left out and the rest placed again
SLACK_FRAMES = 10_000  # frame sets a recording may span beyond twice those it has frames in (5.5 min at 30/s)


@dataclass(frozen=True)
class SlotReport:
    """What placing the frames on one grid did, per camera.

    Attributes:
        restarts: {camera: how many times its frame counter started again within the recording}.
        moved: {camera: frames placed by timestamp (offset != 0)}.
        dropped: {camera: frames that landed on a slot the camera already had}.
        strays: {camera: frame ids (in time order) far outside the recording, left out}, or of frames
            whose timestamp was far from that of their frame id (:meth:`in_span`).
        span: (first, last) frame set of the recording.
    """

    restarts: dict[str, int]
    moved: dict[str, int]
    dropped: dict[str, int]
    strays: dict[str, tuple[int, ...]] = field(default_factory=dict)
    span: tuple[int, int] = (0, -1)

    def in_span(self, ids: tuple[int, ...]) -> tuple[int, ...]:
        """The stray frame ids that are frame sets of the recording: those frames were left out for their
        timestamp, far from that of their frame id, not for their id."""
        return tuple(f for f in ids if self.span[0] <= f <= self.span[1])

    def messages(self) -> list[str]:
        """One plain sentence per camera that restarted, lost frames to a collision or had stray frame ids."""
        out = []
        for cam, ids in sorted(self.strays.items()):
            timed = self.in_span(ids)
            if len(timed) < len(ids):
                far = [f for f in ids if f not in timed]
                which = "a frame id" if len(far) == 1 else "frame ids"
                out.append(f"camera {cam}: {_frames(len(far))} with {which} far outside the recording (from "
                           f"{far[0]}) {_were(len(far))} left out")
            if timed:
                out.append(f"camera {cam}: {_frames(len(timed))} with a timestamp far from that of "
                           f"{'its' if len(timed) == 1 else 'their'} frame id (from frame {timed[0]}) "
                           f"{_were(len(timed))} left out")
        for cam in sorted(set(self.restarts) | set(self.dropped)):
            if self.restarts.get(cam):
                k = self.restarts[cam]
                out.append(f"camera {cam}: frame counter restarted {k} time{'s' * (k != 1)} within the "
                           f"recording (camera restart); {_frames(self.moved.get(cam, 0))} placed by timestamp")
            if self.dropped.get(cam):
                k = self.dropped[cam]
                out.append(f"camera {cam}: {_frames(k)} {'repeat' if k != 1 else 'repeats'} a frame already "
                           f"recorded and {_were(k)} left out")
        return out


def _frames(n: int) -> str:
    return f"{n} frame{'s' * (n != 1)}"


def _were(n: int) -> str:
    return "were" if n != 1 else "was"


def _segments(ids: np.ndarray) -> list[slice]:
    """Slices of ``ids`` (in time order) between the places where the id goes back (the counter restarted)."""
    cuts = np.flatnonzero(np.diff(ids) < 0) + 1
    bounds = [0, *cuts.tolist(), ids.size]
    return [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True) if b > a]


def _period_ns(series: dict[str, tuple[np.ndarray, np.ndarray]]) -> float:
    steps = []
    for ids, ts in series.values():
        for seg in _segments(ids):
            d_id, d_ts = np.diff(ids[seg]), np.diff(ts[seg])
            ok = (d_id > 0) & (d_ts > 0)
            steps.append(d_ts[ok] / d_id[ok])
    steps = np.concatenate(steps) if steps else np.zeros(0)
    return float(np.median(steps)) if steps.size else float(DEFAULT_PERIOD_NS)


def align_frame_slots(series: dict[str, tuple[np.ndarray, np.ndarray]]
                      ) -> tuple[dict[str, tuple[np.ndarray, np.ndarray]], SlotReport]:
    """Place every camera's frames on one frame grid, frames far outside the recording left out.

    Args:
        series: {camera: (frame_ids (N,) int, timestamps_ns (N,) int)} in any order.
    Returns:
        {camera: (order (M,) indices into the camera's input that are kept, slots (M,) int frame set ids)}
        (empty for a camera whose every frame is far outside), and what was moved, restarted, dropped or
        left out.
    """
    series = {cam: (np.asarray(ids, dtype=np.int64), np.asarray(ts, dtype=np.int64)) for cam, (ids, ts) in series.items()}
    timed = {cam: np.lexsort((ids, ts)) for cam, (ids, ts) in series.items()}
    period = _period_ns({cam: (ids[timed[cam]], ts[timed[cam]]) for cam, (ids, ts) in series.items()})
    inside = {cam: _in_line(ids, ts, period) for cam, (ids, ts) in series.items()}  # input indices not stray
    for attempt in range(_PASSES):
        placed, report = _place({cam: (ids[inside[cam]], ts[inside[cam]]) for cam, (ids, ts) in series.items()})
        placed = {cam: (inside[cam][keep], slots) for cam, (keep, slots) in placed.items()}
        lo, hi = recording_span(np.concatenate([np.zeros(0, np.int64), *(slots for _, slots in placed.values())]))
        far = {cam: (slots < lo) | (slots > hi) for cam, (_, slots) in placed.items()}
        if not any(f.any() for f in far.values()):
            break
        inside = {cam: np.setdiff1d(inside[cam], placed[cam][0][far[cam]]) for cam in series}
        if attempt == _PASSES - 1:  # still some after placing again: left out of this placement as it is
            placed = {cam: (keep[~far[cam]], slots[~far[cam]]) for cam, (keep, slots) in placed.items()}
    strays = {}
    for cam, (ids, ts) in series.items():
        out = np.setdiff1d(np.arange(ids.size), inside[cam])
        if out.size:
            strays[cam] = tuple(ids[out[np.lexsort((ids[out], ts[out]))]].tolist())
    report = SlotReport(report.restarts, report.moved, report.dropped, strays, (lo, hi))
    for message in report.messages():
        log.warning("%s", message)
    return placed, report


def _in_line(ids: np.ndarray, ts: np.ndarray, period_ns: float) -> np.ndarray:
    """Indices of the camera's frames whose id is in line with the frames around them in time.

    Along one frame counter, frame id minus frame time (in periods) is constant (lost frames included); it
    jumps at a counter restart, and at a stray id. Frames in time order are cut into runs where it jumps by
    more than :data:`SLACK_FRAMES`; a run shorter than :data:`_SHORT_RUN` frames between two longer runs
    that are in line with each other (the counter went on across it: no restart), and not in line with
    them itself, is stray. Short runs at either end of the series are kept here (the recording's span
    judges them) unless their frames are more than :data:`SLACK_FRAMES` periods in time from the runs
    next to them: a timestamp far off (stamped early, it would otherwise be the camera's first counter)."""
    if not ids.size:
        return np.zeros(0, dtype=np.int64)
    order = np.lexsort((ids, ts))
    lag = ids[order] - np.round((ts[order] - ts.min()) / period_ns).astype(np.int64)
    cuts = np.flatnonzero(np.abs(np.diff(lag)) > SLACK_FRAMES) + 1
    starts, stops = np.r_[0, cuts], np.r_[cuts, lag.size]
    runs = np.flatnonzero(stops - starts >= _SHORT_RUN)
    kept = np.ones(lag.size, dtype=bool)
    if runs.size:  # frames before the first long run and after the last, far from it in time
        t, head, tail = ts[order], int(starts[runs[0]]), int(stops[runs[-1]])
        kept[:head] = t[head] - t[:head] <= SLACK_FRAMES * period_ns
        kept[tail:] = t[tail:] - t[tail - 1] <= SLACK_FRAMES * period_ns
    for before, after in zip(runs[:-1].tolist(), runs[1:].tolist(), strict=True):
        counter = int(lag[stops[before] - 1])
        if after == before + 1 or abs(int(lag[starts[after]]) - counter) > SLACK_FRAMES:
            continue  # nothing between, or a restart between: keep
        for run in range(before + 1, after):
            if abs(int(lag[starts[run]]) - counter) > SLACK_FRAMES:
                kept[starts[run] : stops[run]] = False
    return np.sort(order[kept])


def recording_span(slots: np.ndarray) -> tuple[int, int]:
    """(first, last) frame set of the recording from every frame's slot (all cameras): the slots cut at
    their widest gaps, keeping the side with more frames, until the span is at most twice the frame sets
    with frames plus :data:`SLACK_FRAMES` (the memory a reader allocates stays bounded by the data)."""
    if not slots.size:
        return 0, -1
    uniq, counts = np.unique(slots, return_counts=True)
    cuts = np.flatnonzero(np.diff(uniq) > 2 * uniq.size + SLACK_FRAMES) + 1  # never inside the recording
    bounds = [0, *cuts.tolist(), uniq.size]
    runs = [(int(counts[a:b].sum()), -a, a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
    _, _, a, b = max(runs)  # the most frames; the earliest on a tie
    while uniq[b - 1] - uniq[a] + 1 > 2 * (b - a) + SLACK_FRAMES:
        cut = a + int(np.argmax(np.diff(uniq[a:b]))) + 1
        a, b = (a, cut) if counts[a:cut].sum() >= counts[cut:b].sum() else (cut, b)
    return int(uniq[a]), int(uniq[b - 1])


def _place(series: dict[str, tuple[np.ndarray, np.ndarray]]
           ) -> tuple[dict[str, tuple[np.ndarray, np.ndarray]], SlotReport]:
    """Every camera's frames on one grid (see the module): (kept input indices, slots) per camera."""
    ordered = {}
    for cam, (ids, ts) in series.items():
        order = np.lexsort((ids, ts))  # time order; equal stamps by id
        ordered[cam] = (order, ids[order], ts[order])
    period = _period_ns({c: (i, t) for c, (_, i, t) in ordered.items()})
    ref = min((int(t.min()) for _, _, t in ordered.values() if t.size), default=0)
    firsts = [(t[s] - ref) - i[s] * period for _, i, t in ordered.values() if i.size
              for s in _segments(i)[:1]]
    anchor = float(np.median(np.concatenate(firsts))) if firsts else 0.0
    out, restarts, moved, dropped = {}, {}, {}, {}
    for cam, (order, ids, ts) in ordered.items():
        slots = ids.copy()
        segs = _segments(ids)
        for seg in segs[1:]:  # the first segment counts from the synchronised start: its ids are the slots
            offset = int(np.median(np.round(((ts[seg] - ref) - anchor) / period) - ids[seg]))
            slots[seg] += offset
            if offset:
                moved[cam] = moved.get(cam, 0) + (seg.stop - seg.start)
        _, first = np.unique(slots, return_index=True)  # the first frame (in time) of each slot
        keep = np.sort(first)
        restarts[cam] = max(0, len(segs) - 1)
        dropped[cam] = int(slots.size - keep.size)
        out[cam] = (order[keep], slots[keep])
    report = SlotReport({c: n for c, n in restarts.items() if n}, moved, {c: n for c, n in dropped.items() if n})
    return out, report
