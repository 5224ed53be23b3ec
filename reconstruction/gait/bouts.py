"""Walking bouts, turns and standing from the body centre; the line of progression of each pass.

Method: the horizontal body centre (mid-hip, else the feet) is smoothed with a moving average of about
one stride (``bout_smoothing_s``) so the step-to-step sway cancels. Frames faster than
``min_walking_speed_mm_s`` are walking, the rest standing. Walking frames whose heading turns faster
than ``max_turn_rate_deg_s``, or that deviate from their pass's median heading by more than
``max_heading_deviation_deg``, are turns. Straight walking runs of at least ``min_pass_s``, trimmed to
where the speed is at least ``steady_speed_fraction`` of their median (no starting or stopping), are
passes.
Bias: the smoothing widens turns and standing by up to half a window, so a step right next to a turn
may be dropped; steps are never invented.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.gait.config import GaitConfig
from gaitcap.reconstruction.gait.tracks import CENTER, FootTracks
from scipy.ndimage import uniform_filter1d

#: The kinds of segment in which the person walks.
WALKING = ("pass", "turn", "transition")


@dataclass(frozen=True)
class Segment:
    """A stretch of the trial: kind is "pass" (straight steady walking), "turn", "transition" (straight but
    speeding up or slowing down), "standing" or "gap" (no data); times in s."""

    kind: str
    start_s: float
    end_s: float


@dataclass(frozen=True)
class Pass:
    """One straight walking pass.

    Attributes:
        index: 0-based pass number in the trial.
        start_s, end_s: time span (s).
        direction: (2,) unit horizontal direction of progression (x, y).
        speed_mm_s: median body-centre speed during the pass (mm/s).
    """

    index: int
    start_s: float
    end_s: float
    direction: tuple[float, float]
    speed_mm_s: float

    def contains(self, t_s: float) -> bool:
        return self.start_s <= t_s <= self.end_s


@dataclass(frozen=True)
class Bouts:
    """Segmentation of a trial: segments in time order and the passes among them."""

    segments: tuple[Segment, ...]
    passes: tuple[Pass, ...]

    def pass_at(self, t_s: float) -> Pass | None:
        return next((p for p in self.passes if p.contains(t_s)), None)

    def walking(self, times_s: np.ndarray) -> np.ndarray:
        """(T,) bool: the frames at ``times_s`` inside a segment of walking (a pass, a transition or a
        turn; not standing, not a gap)."""
        t = np.asarray(times_s, dtype=np.float64)
        out = np.zeros(t.shape, dtype=bool)
        for s in self.segments:
            if s.kind in WALKING:
                out |= (t >= s.start_s) & (t <= s.end_s)
        return out


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(int), 0]))
    return list(zip(edges[::2].tolist(), (edges[1::2] - 1).tolist(), strict=True))


def _centre_motion(tracks: FootTracks, config: GaitConfig):
    times = tracks.times_s
    dt = float(np.median(np.diff(times)))
    window = max(1, int(round(config.bout_smoothing_s / dt)))
    xy = uniform_filter1d(tracks.frames_mm[:, CENTER, :2], window, axis=0, mode="nearest")
    vel = np.gradient(xy, times, axis=0)
    speed = np.linalg.norm(vel, axis=1)
    heading = np.unwrap(np.arctan2(vel[:, 1], vel[:, 0]))
    # Heading rate over one smoothing window (a frame-to-frame gradient would amplify noise).
    half = max(1, window // 2)
    ahead = heading[np.minimum(np.arange(len(times)) + half, len(times) - 1)]
    behind = heading[np.maximum(np.arange(len(times)) - half, 0)]
    span = times[np.minimum(np.arange(len(times)) + half, len(times) - 1)] - times[
        np.maximum(np.arange(len(times)) - half, 0)]
    rate = np.degrees(np.abs(ahead - behind) / span)
    return vel, speed, heading, rate


def find_bouts(tracks: FootTracks, config: GaitConfig = GaitConfig()) -> Bouts:
    """Split a trial into passes, turns and standing (see the module docstring)."""
    times = tracks.times_s
    vel, speed, heading, rate = _centre_motion(tracks, config)
    valid = tracks.valid[:, CENTER]
    walking = (speed > config.min_walking_speed_mm_s) & valid
    straight = walking & (rate <= config.max_turn_rate_deg_s)
    # Second pass: within each straight run, frames far from the run's median heading are turns too.
    for a, b in _runs(straight):
        med = np.median(heading[a:b + 1])
        dev = np.degrees(np.abs(heading[a:b + 1] - med))
        straight[a:b + 1] &= dev <= config.max_heading_deviation_deg
    # Steady walking only: the ends of a pass where the body is still speeding up or slowing down
    # (starting from standing, stopping, leaving a turn) are not part of it.
    unsteady = np.zeros_like(straight)
    for a, b in _runs(straight):
        steady = speed[a:b + 1] >= config.steady_speed_fraction * np.median(speed[a:b + 1])
        inside = np.flatnonzero(steady)
        straight[a:b + 1] = False
        unsteady[a:b + 1] = True
        if len(inside):
            straight[a + inside[0]:a + inside[-1] + 1] = True
    unsteady &= ~straight
    passes = []
    for a, b in _runs(straight):
        if times[b] - times[a] < config.min_pass_s:
            straight[a:b + 1] = False
            continue
        v = vel[a:b + 1].sum(axis=0)
        direction = v / np.linalg.norm(v)
        passes.append(Pass(len(passes), float(times[a]), float(times[b]),
                           (float(direction[0]), float(direction[1])), float(np.median(speed[a:b + 1]))))
    kinds = np.where(straight, 0, np.where(unsteady, 4, np.where(walking, 1, np.where(valid, 2, 3))))
    segments = []
    edges = np.flatnonzero(np.diff(kinds)) + 1
    for a, b in zip(np.r_[0, edges], np.r_[edges, len(times)], strict=True):
        kind = ("pass", "turn", "standing", "gap", "transition")[kinds[a]]
        segments.append(Segment(kind, float(times[a]), float(times[b - 1])))
    return Bouts(tuple(segments), tuple(passes))
