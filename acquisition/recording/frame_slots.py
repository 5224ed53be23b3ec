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
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

log = logging.getLogger(__name__)

DEFAULT_PERIOD_NS = 1_000_000_000 // 30


@dataclass(frozen=True)
class SlotReport:
    """What placing the frames on one grid did, per camera.

    Attributes:
        restarts: {camera: how many times its frame counter started again within the recording}.
        moved: {camera: frames placed by timestamp (offset != 0)}.
        dropped: {camera: frames that landed on a slot the camera already had}.
    """

    restarts: dict[str, int]
    moved: dict[str, int]
    dropped: dict[str, int]

    def messages(self) -> list[str]:
        """One plain sentence per camera that restarted or lost frames to a collision."""
        out = []
        for cam in sorted(set(self.restarts) | set(self.dropped)):
            if self.restarts.get(cam):
                out.append(f"camera {cam}: frame counter restarted {self.restarts[cam]} time(s) within the "
                           f"recording (camera restart); {self.moved.get(cam, 0)} frames placed by timestamp")
            if self.dropped.get(cam):
                out.append(f"camera {cam}: {self.dropped[cam]} frames repeat a frame already recorded and were "
                           "left out")
        return out


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
    """Place every camera's frames on one frame grid.

    Args:
        series: {camera: (frame_ids (N,) int, timestamps_ns (N,) int)} in any order.
    Returns:
        {camera: (order (M,) indices into the camera's input that are kept, slots (M,) int frame set ids)},
        and what was moved, restarted or dropped.
    """
    ordered = {}
    for cam, (ids, ts) in series.items():
        ids, ts = np.asarray(ids, dtype=np.int64), np.asarray(ts, dtype=np.int64)
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
        restarts[cam] = len(segs) - 1
        dropped[cam] = int(slots.size - keep.size)
        out[cam] = (order[keep], slots[keep])
    report = SlotReport({c: n for c, n in restarts.items() if n}, moved, {c: n for c, n in dropped.items() if n})
    for message in report.messages():
        log.warning("%s", message)
    return out, report
