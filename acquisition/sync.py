"""Synchronisation: group frames from all cameras into frame sets by timestamp and check the lab's criteria.

Frames are assigned to slots of one frame period: ``slot = round((timestamp_ns - t0_ns) / period_ns)``
with ``t0_ns`` the median first timestamp over the cameras; or, when the cameras' frame ids count from
one synchronised start (the FLIR and simulated drivers), ``slot = frame_id``. From timestamps alone a
camera offset by more than half a period is ambiguous (it lands in the neighbouring set), so pass frame
ids to measure spreads near the 30 ms criterion at 30 fps. A frame set is one slot; a camera missing
from a slot between its first and the trial's last slot is a skip (a dropped frame), a camera with two
frames in one slot a duplicate. The spread of a set is max - min timestamp over the cameras present.

Pass criteria of the lab (Cotton et al.'s rig): 0 skips or duplicates, >= 28 fps at 30 fps, timestamp
spread across cameras <= 30 ms.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

MISSING = -1


@dataclass(frozen=True)
class PassCriteria:
    """Acquisition pass criteria (defaults: the lab's)."""

    max_skips: int = 0
    max_duplicates: int = 0
    min_fps: float = 28.0
    max_spread_ms: float = 30.0


@dataclass(frozen=True, eq=False)
class FrameSets:
    """Frames of C cameras grouped into S frame sets.

    Attributes:
        cameras: (C,) camera names.
        timestamps_ns: (S, C) int64 timestamp of each camera's frame in each set, -1 where missing.
        index: (S, C) int64 position of that frame in the camera's input sequence, -1 where missing.
        slots: (S,) slot number of each set (frame periods since t0).
        period_ns: the frame period used.
        duplicates: {camera: number of frames that fell into an already filled slot}.
    """

    cameras: tuple[str, ...]
    timestamps_ns: np.ndarray
    index: np.ndarray
    slots: np.ndarray
    period_ns: int
    duplicates: dict[str, int]

    @property
    def present(self) -> np.ndarray:
        """(S, C) bool."""
        return self.index != MISSING

    def spread_ms(self) -> np.ndarray:
        """(S,) max - min timestamp over the cameras present in each set, in ms (0 for single frames)."""
        ts = np.where(self.present, self.timestamps_ns, 0).astype(np.float64)
        hi = np.where(self.present, ts, -np.inf).max(axis=1)
        lo = np.where(self.present, ts, np.inf).min(axis=1)
        return np.where(np.isfinite(hi - lo), hi - lo, 0.0) / 1e6

    def skips(self) -> dict[str, int]:
        """{camera: missing slots between its first frame and the last set}."""
        out = {}
        for c, name in enumerate(self.cameras):
            seen = np.flatnonzero(self.present[:, c])
            out[name] = 0 if seen.size == 0 else int(np.sum(~self.present[seen[0] :, c]))
        return out


def group_frames(
    timestamps_ns: Mapping[str, np.ndarray], *, period_ns: int, t0_ns: int | None = None,
    frame_ids: Mapping[str, np.ndarray] | None = None,
) -> FrameSets:
    """Group each camera's frame timestamps (ns, in delivery order) into frame sets of one period
    (by frame id when ``frame_ids`` are given for every camera)."""
    if period_ns <= 0:
        raise ValueError(f"period_ns: must be > 0, got {period_ns}")
    cams = tuple(timestamps_ns)
    if not cams:
        raise ValueError("timestamps_ns: no cameras")
    series = {c: np.asarray(timestamps_ns[c], dtype=np.int64).reshape(-1) for c in cams}
    firsts = [s[0] for s in series.values() if s.size]
    if not firsts:
        raise ValueError("timestamps_ns: no frames from any camera")
    t0 = int(np.median(firsts)) if t0_ns is None else int(t0_ns)
    if frame_ids is not None:
        missing = sorted(set(cams) - set(frame_ids))
        if missing:
            raise ValueError(f"frame_ids: none given for cameras {missing}")
        slot_of = {c: np.asarray(frame_ids[c], dtype=np.int64).reshape(-1) for c in cams}
        bad = [c for c in cams if slot_of[c].shape != series[c].shape]
        if bad:
            raise ValueError(f"frame_ids: not one per timestamp for cameras {bad}")
    else:
        slot_of = {c: np.rint((s - t0) / period_ns).astype(np.int64) for c, s in series.items()}
    all_slots = np.unique(np.concatenate([v for v in slot_of.values()]))
    first, last = int(all_slots.min()), int(all_slots.max())
    slots = np.arange(first, last + 1)
    ts = np.full((slots.size, len(cams)), MISSING, dtype=np.int64)
    index = np.full_like(ts, MISSING)
    duplicates = {}
    for c, name in enumerate(cams):
        rows = slot_of[name] - first
        dup = 0
        for i, row in enumerate(rows):
            if index[row, c] != MISSING:
                dup += 1
                continue
            index[row, c] = i
            ts[row, c] = series[name][i]
        duplicates[name] = dup
    return FrameSets(cams, ts, index, slots, int(period_ns), duplicates)


def camera_fps(timestamps_ns: np.ndarray) -> float:
    """Delivered frame rate (frames/s) of one camera: (frames - 1) / (last - first timestamp)."""
    ts = np.asarray(timestamps_ns, dtype=np.int64)
    if ts.size < 2 or ts[-1] <= ts[0]:
        return 0.0
    return float((ts.size - 1) / ((ts[-1] - ts[0]) / 1e9))


@dataclass(frozen=True)
class SyncReport:
    """Per-camera and per-set figures and the pass verdict."""

    cameras: tuple[str, ...]
    num_sets: int
    skips: dict[str, int]
    duplicates: dict[str, int]
    fps: dict[str, float]
    spread_ms_median: float
    spread_ms_max: float
    problems: tuple[str, ...]

    @property
    def passed(self) -> bool:
        return not self.problems

    def to_dict(self) -> dict:
        return {
            "cameras": list(self.cameras),
            "num_sets": self.num_sets,
            "skips": self.skips,
            "duplicates": self.duplicates,
            "fps": self.fps,
            "spread_ms_median": self.spread_ms_median,
            "spread_ms_max": self.spread_ms_max,
            "passed": self.passed,
            "problems": list(self.problems),
        }


def check_sync(
    timestamps_ns: Mapping[str, np.ndarray],
    *,
    period_ns: int,
    criteria: PassCriteria = PassCriteria(),
    frame_ids: Mapping[str, np.ndarray] | None = None,
) -> SyncReport:
    """Group the frames and judge them against ``criteria``; ``problems`` names each failing camera."""
    sets = group_frames(timestamps_ns, period_ns=period_ns, frame_ids=frame_ids)
    skips = sets.skips()
    fps = {c: camera_fps(timestamps_ns[c]) for c in sets.cameras}
    spread = sets.spread_ms()
    problems = []
    for c in sets.cameras:
        if skips[c] > criteria.max_skips:
            problems.append(f"camera {c}: {skips[c]} skipped frames")
        if sets.duplicates[c] > criteria.max_duplicates:
            problems.append(f"camera {c}: {sets.duplicates[c]} duplicate frames")
        if fps[c] < criteria.min_fps:
            problems.append(f"camera {c}: {fps[c]:.2f} fps < {criteria.min_fps}")
    spread_max = float(spread.max()) if spread.size else 0.0
    if spread_max > criteria.max_spread_ms:
        worst = int(np.argmax(spread))
        problems.append(
            f"frame set {worst}: timestamp spread {spread_max:.1f} ms > {criteria.max_spread_ms} ms"
        )
    return SyncReport(
        cameras=sets.cameras,
        num_sets=int(sets.slots.size),
        skips=skips,
        duplicates=sets.duplicates,
        fps=fps,
        spread_ms_median=float(np.median(spread)) if spread.size else 0.0,
        spread_ms_max=spread_max,
        problems=tuple(problems),
    )
