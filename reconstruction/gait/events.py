"""Heel strike and toe off of each foot from heel and toe kinematics alone.

Contacts: a foot is on the ground while its heel or its toe is at rest, i.e. slower than
``v_rest = max(min_rest_speed_mm_s, rest_speed_fraction x walking speed, rest_noise_factor x the feet's
speed noise at rest)``, and heel or toe is within ``max_contact_lift_mm`` of its stance height. Contacts
shorter than ``min_stance_s``, swings shorter than ``min_swing_s`` and "swings" after which the heel
rests less than ``min_foot_travel_mm`` from where it was are noise and removed. Heel and toe positions at
a contact are the median of each point over the frames of the contact when that point is at rest.
Contacts cut by the start or end of the recording are kept (2 frames suffice) for the event that lies
inside it; the other is NaN. A stance whose end alone is in the recording is also found by the toe
staying near where it is at the first frame (its speed may not look still: a rolling toe, a fit's edge).

Heel strike (initial contact, the first instant of ground contact): real feet reach the floor still
moving; the heel rolls over the heel rocker and comes to rest 60-130 ms later (see
``gaitcap.simulator.foot``), so the moment the foot comes to rest is 2-3 frames late at 30 fps. How far
it rolls is its speed at contact times that time, and the heel arrives slower in a slower gait (at the
annotated contacts of two real walks, a median 26 mm from rest at 1.25 m/s, 17 mm at 0.65 m/s). The
heel strike is the first time heel or toe comes within the distance walked in ``contact_walking_s``
(25 ms: 30 mm at 1.2 m/s), at least ``contact_distance_mm`` (20 mm), of where it rests in this contact
(``contact_distance``), located on the continuous trajectory (the caller's sampler, else a cubic spline
through the frames) at ``event_resolution_s``. A fixed 30 mm found the contacts of slow and shuffling
gaits early by the time their heels took to cover the difference (the walker's Parkinsonian and
hemiparetic patterns: -40 and -29 ms; with the distance scaled: -15 and 0 ms). A position threshold is
also far less sensitive to noise than a speed threshold. Where no such crossing exists in the window (a
contact without a clear approach) the older speed criterion is the fallback: where the foot's speed
falls below the event speed (3 x the noise at rest, at least ``min_event_speed_mm_s``), extrapolated to
zero speed on a caller's continuous trajectory. Toe-first contacts are located by the toe in the same
way.

Heel-first landings: a heel point behind the heel's floor contact (the posterior heel marker, a detector's
heel keypoint) dips below its stance height when the foot lands pitched toe up (by the distance behind
the contact x the sine of the pitch: 5-15 mm at 10-20 degrees), and rises again as the foot rolls flat
about that contact, so its lowest point is where the heel stops descending: the impact. Where the heel's
lowest point within ``heel_landing_window_s`` after the distance crossing is at least
``heel_landing_dip_mm`` (and ``heel_landing_noise_factor`` x the noise of its height in the contact)
below its stance height and the foot is pitched at least ``heel_landing_pitch_deg`` more toe up than in
stance, enough to explain the dip (a heel point at most ``heel_landing_lever_mm`` behind the contact; on
the real walks' markers dip / sin(pitch) is 28-49 mm), that lowest point is the heel strike. Flat (no dip) and toe-first (no pitch) contacts keep the
distance crossing. On real walks with force plates a heel can arrive horizontally first and drop its last
10-20 mm almost vertically (the distance crossing is then 30-60 ms early); see docs/gait.md.

Toe off (the last instant of contact): the last time the toe is within ``toe_off_distance_mm`` of its
rest point, refined to the moment the toe is farthest behind the body centre along the foot's direction
within ``toe_off_window_s`` of that (Zeni et al. 2008, Gait & Posture 27:710-714; a toe keypoint at the tip
of the toe, which pivots until it leaves, and a forefoot marker, which moves before, both give it within
about 15 ms). Fallbacks: midway between that distance crossing and the first time the foot's speed
exceeds ``toe_off_peak_fraction`` of the following swing's peak, else the speed crossing.

Known biases (30 fps): on the synthetic walker (heel_roll_mm 30, ground-truth frames) heel strike 0 ms,
toe off +15 ms; feet that roll less than that distance after contact are found early by the time they
take to cover the difference, feet that roll more late (the walker's Parkinsonian pattern, 15 mm at
0.78 m/s: -15 ms; slow, 25 mm at 0.83 m/s: +9 ms). On the real walks of ``bench/gait_real.py`` see
docs/gait.md. Noise raises the rest points' spread; noisy frames are smoothed (``smoothing_window_s``),
which blurs the events; so does a trajectory fit that rounds the foot's stop and push-off: the implicit
fit's 8 Hz time model finds heel-first landings 4-15 ms late even from noise-free detections, and a
reconstruction whose heel is off by about the dip (5-7 mm near contact on the real walks with the paper's
detector noise) flips the heel-first test between contacts of one walk (docs/gait.md, "What limits the
heel-strike target per walk").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.gait.config import GaitConfig
from gaitcap.reconstruction.gait.tracks import CENTER, HEEL, SIDES, TOE, FootTracks


@dataclass(frozen=True)
class Contact:
    """One foot contact (footfall).

    Attributes:
        foot: "left" or "right".
        heel_strike_s: initial contact (s); NaN if the contact began before the data.
        toe_off_s: last contact (s); NaN if it ended after the data.
        heel_mm: (3,) stationary heel point (mm).
        toe_mm: (3,) stationary toe point (mm).
        heel_spread_mm: median horizontal distance of the resting heel from heel_mm (mm).
        valid: heel strike located and no untrusted data gap during the contact (toe off may be NaN).
    """

    foot: str
    heel_strike_s: float
    toe_off_s: float
    heel_mm: tuple[float, float, float]
    toe_mm: tuple[float, float, float]
    heel_spread_mm: float
    valid: bool


@dataclass(frozen=True)
class EventTiming:
    """How finely a trial's events are located in time (each report says it).

    Attributes:
        located_on: "continuous trajectory" (the caller's ``sample``, e.g. a refined fit: the events are
            found between frames) or "spline through frames" (a triangulated, frame-grid trajectory: the
            spline only interpolates between the frames, where the foot was measured).
        frame_interval_s: median time between frames (s).
        search_step_s: step of the event search on that function (s; ``GaitConfig.event_resolution_s``).
        resolution_s: the events' time resolution (s): the search step on a continuous trajectory, one
            frame interval on frames.
    """

    located_on: str
    frame_interval_s: float
    search_step_s: float
    resolution_s: float

    @property
    def sub_frame(self) -> bool:
        """Whether the events resolve times finer than a frame."""
        return self.resolution_s < self.frame_interval_s

    def to_dict(self) -> dict:
        return {"located_on": self.located_on, "frame_interval_s": self.frame_interval_s,
                "search_step_s": self.search_step_s, "resolution_s": self.resolution_s,
                "sub_frame": self.sub_frame}


def event_timing(tracks: FootTracks, config: GaitConfig = GaitConfig()) -> EventTiming:
    """The :class:`EventTiming` of events found on ``tracks``."""
    dt = float(np.median(np.diff(tracks.times_s)))
    step = float(config.event_resolution_s)
    if tracks.continuous:
        return EventTiming("continuous trajectory", dt, step, min(step, dt))
    return EventTiming("spline through frames", dt, step, dt)


def rest_speed_mm_s(walking_speed_mm_s: float, config: GaitConfig, noise_mm_s: float = 0.0) -> float:
    """The rest-speed threshold (mm/s) for a trial walked at ``walking_speed_mm_s`` whose feet show a
    speed noise floor ``noise_mm_s`` at rest (see ``FootTracks.rest_noise_mm_s``)."""
    return max(config.min_rest_speed_mm_s, config.rest_speed_fraction * walking_speed_mm_s,
               config.rest_noise_factor * noise_mm_s)


def contact_distance(walking_speed_mm_s: float, config: GaitConfig = GaitConfig()) -> float:
    """Distance (mm) from its rest point within which a foot arriving at a trial walked at
    ``walking_speed_mm_s`` is in contact: the distance walked in ``contact_walking_s``, at least
    ``contact_distance_mm`` (see the module docstring)."""
    return max(config.contact_distance_mm, config.contact_walking_s * walking_speed_mm_s)


def _clean(mask: np.ndarray, times_s: np.ndarray, min_false_s: float, min_true_s: float) -> np.ndarray:
    """Fill short interior False runs, then drop short True runs."""
    out = mask.copy()
    for value, min_s, interior_only in ((False, min_false_s, True), (True, min_true_s, False)):
        edges = np.flatnonzero(np.diff(np.r_[0, (out == value).astype(int), 0]))
        for a, b in zip(edges[::2], edges[1::2], strict=True):
            if interior_only and (a == 0 or b == len(out)):
                continue
            span = times_s[min(b, len(out) - 1)] - times_s[max(a - 1, 0)]
            if span < min_s:
                out[a:b] = not value
    return out


def _crossings(tracks: FootTracks, side: str, brackets: np.ndarray, v_event: float, *, falling: bool,
               resolution_s: float) -> np.ndarray:
    """Sub-frame times where min(heel, toe) speed crosses v_event inside each (t0, t1) bracket.

    falling: the first time the speed drops below v_event (heel strike); else the time it last rises
    above it (toe off). Linear interpolation between samples ``resolution_s`` apart.
    """
    if len(brackets) == 0:
        return np.zeros(0)
    n = max(2, int(np.ceil(np.max(brackets[:, 1] - brackets[:, 0]) / resolution_s)) + 1)
    grid = brackets[:, :1] + (brackets[:, 1:] - brackets[:, :1]) * np.linspace(0.0, 1.0, n)  # (E, n)
    speed = tracks.speed_mm_s(grid.ravel())
    f = (np.minimum(speed[:, HEEL[side]], speed[:, TOE[side]]) - v_event).reshape(grid.shape)
    out = np.empty(len(brackets))
    for e in range(len(brackets)):
        below = np.flatnonzero(f[e] < 0)
        if len(below) == 0:  # never that slow: fall back to the middle of the bracket
            out[e] = 0.5 * (grid[e, 0] + grid[e, -1])
            continue
        j0, j1 = (below[0] - 1, below[0]) if falling else (below[-1], below[-1] + 1)
        if j0 < 0 or j1 >= n:
            out[e] = grid[e, max(min(j1, n - 1), 0)]
            continue
        f0, f1 = f[e, j0], f[e, j1]
        w = f0 / (f0 - f1) if f0 != f1 else 0.0
        out[e] = grid[e, j0] + np.clip(w, 0.0, 1.0) * (grid[e, j1] - grid[e, j0])
    return out


def _events(tracks: FootTracks, side: str, brackets: np.ndarray, v_event: float, *, falling: bool,
            config: GaitConfig, dt: float) -> np.ndarray:
    """Event times in each bracket: the crossing of v_event, extrapolated to zero speed when
    ``extrapolate_events`` (speed ~ (t - t_event)^2 near the event, as for a smooth landing: the crossing
    of v and of 4 v are then as far apart as the crossing of v is from the event)."""
    t1 = _crossings(tracks, side, brackets, v_event, falling=falling, resolution_s=config.event_resolution_s)
    extrapolate = tracks.continuous if config.extrapolate_events is None else config.extrapolate_events
    if not extrapolate or len(brackets) == 0:
        return t1
    t4 = _crossings(tracks, side, brackets, 4 * v_event, falling=falling, resolution_s=config.event_resolution_s)
    gap = (t1 - t4) if falling else (t4 - t1)
    ok = (gap >= 0) & (gap <= dt)  # only a short, smooth approach is extrapolated
    return np.where(ok, t1 + gap if falling else t1 - gap, t1)


def _rest_point(points_mm: np.ndarray, speed: np.ndarray, v_rest: float) -> tuple[np.ndarray, float]:
    """Median of a point (F, 3) over its at-rest frames and the horizontal spread around it (mm)."""
    rest = speed < v_rest
    if not rest.any():
        rest = speed <= speed.min()
    pts = points_mm[rest]
    centre = np.median(pts, axis=0)
    spread = float(np.median(np.linalg.norm(pts[:, :2] - centre[:2], axis=1)))
    return centre, spread


def _departures(tracks: FootTracks, side: str, anchors_s: np.ndarray, limits_s: np.ndarray, v_rest: float,
                config: GaitConfig) -> np.ndarray:
    """Toe-off times: the first time after each anchor (end of rest) that the foot's speed exceeds
    ``toe_off_peak_fraction`` x its peak swing speed (at least v_rest), searched up to the next contact
    (``limits_s``). NaN where the swing has no clear peak. A departing foot accelerates briskly, so a
    level well above the wobble of a fitted trajectory during heel rise costs only a few ms."""
    out = np.full(len(anchors_s), np.nan)
    if len(anchors_s) == 0:
        return out
    offsets = np.arange(0.0, config.event_window_s, config.event_resolution_s)
    grid = anchors_s[:, None] + offsets[None, :]
    speed = tracks.speed_mm_s(grid.ravel())
    s = np.minimum(speed[:, HEEL[side]], speed[:, TOE[side]]).reshape(grid.shape)
    s = np.where(grid <= limits_s[:, None], s, 0.0)
    for e in range(len(anchors_s)):
        level = max(v_rest, config.toe_off_peak_fraction * float(np.max(s[e])))
        above = np.flatnonzero(s[e] >= level)
        if len(above) == 0 or above[0] == 0 or level <= v_rest:
            continue
        j = above[0]
        f0, f1 = s[e, j - 1] - level, s[e, j] - level
        out[e] = grid[e, j - 1] + (f0 / (f0 - f1) if f0 != f1 else 1.0) * (grid[e, j] - grid[e, j - 1])
    return out


def _event_speed(heel_speed, toe_speed, rest, v_rest: float, config: GaitConfig) -> float:
    """Speed whose crossing marks an event: ``event_noise_factor`` x the median foot speed while at rest
    (the trajectory's noise floor), at least ``min_event_speed_mm_s`` and at most ``v_rest``."""
    still = np.minimum(heel_speed, toe_speed)[rest]
    noise = float(np.median(still)) if len(still) else v_rest
    return float(np.clip(config.event_noise_factor * noise, config.min_event_speed_mm_s, v_rest))


def _merge_in_place(runs: list[tuple[int, int]], heel_mm: np.ndarray, heel_speed: np.ndarray,
                    v_rest: float, min_travel_mm: float) -> list[tuple[int, int]]:
    """Merge consecutive contacts whose heel rest points are closer than ``min_travel_mm`` horizontally:
    the foot did not go anywhere, so the "swing" between them was noise (or a shuffle in place)."""
    merged: list[tuple[int, int]] = []
    for a, b in runs:
        if merged:
            pa, pb = merged[-1]
            prev, _ = _rest_point(heel_mm[pa:pb + 1], heel_speed[pa:pb + 1], v_rest)
            this, _ = _rest_point(heel_mm[a:b + 1], heel_speed[a:b + 1], v_rest)
            if np.linalg.norm(prev[:2] - this[:2]) < min_travel_mm:
                merged[-1] = (pa, b)
                continue
        merged.append((a, b))
    return merged


def _contact_runs(tracks: FootTracks, side: str, speed: np.ndarray, v_rest: float, config: GaitConfig):
    """Frame runs (first, last) of one foot's contacts, and the cleaned (T,) at-rest mask."""
    times, frames = tracks.times_s, tracks.frames_mm
    h, t = HEEL[side], TOE[side]
    dt = float(np.median(np.diff(times)))
    z_heel = np.percentile(frames[tracks.valid[:, h], h, 2], 10)
    z_toe = np.percentile(frames[tracks.valid[:, t], t, 2], 10)
    low = ((frames[:, h, 2] - z_heel) < config.max_contact_lift_mm) | (
        (frames[:, t, 2] - z_toe) < config.max_contact_lift_mm)
    rest = _clean((np.minimum(speed[:, h], speed[:, t]) < v_rest) & low, times, config.min_swing_s, 0.0)
    edges = np.flatnonzero(np.diff(np.r_[0, rest.astype(int), 0]))
    runs = _merge_in_place(list(zip(edges[::2], edges[1::2] - 1, strict=True)), frames[:, h],
                           speed[:, h], v_rest, config.min_foot_travel_mm)
    # Short contacts go only now, so that a blip inside a stance cannot cut off the stance's end. A contact
    # cut by the start or end of the recording (within min_stance_s of it) is kept if it lasts 2 frames.
    def kept(a: int, b: int) -> bool:
        if times[b] - times[a] + dt >= config.min_stance_s:
            return True
        cut = times[a] - times[0] < config.min_stance_s or times[-1] - times[b] < config.min_stance_s
        return cut and b > a
    return [(a, b) for a, b in runs if kept(a, b)], rest


def _first_below(grid: np.ndarray, dist: np.ndarray, level: float, anchor: int) -> float:
    """Time where ``dist`` (N,) last falls below ``level`` at or before grid index ``anchor`` (the foot
    arriving), or first falls below after it when it is still above there (a foot that pivots into its
    rest, as in a turn); NaN when it is below over the whole window up to ``anchor`` (the arrival is not in
    it) or never falls below after it. Always between two samples that bracket the level: a time
    extrapolated from two samples above it would lie anywhere (seconds outside the window)."""
    above = np.flatnonzero(dist[: anchor + 1] >= level)
    if len(above) == 0:
        return float("nan")
    j = above[-1]
    if j + 1 >= len(grid):
        return float(grid[j])
    if j == anchor and not dist[j + 1] < level:
        below = np.flatnonzero(dist[j + 1:] < level)
        if len(below) == 0:
            return float("nan")
        j += int(below[0])
    f0, f1 = dist[j] - level, dist[j + 1] - level
    return float(grid[j] + (f0 / (f0 - f1) if f0 != f1 else 0.0) * (grid[j + 1] - grid[j]))


def _near_rest(tracks: FootTracks, side: str, run: tuple[int, int], heel_mm, toe_mm, config: GaitConfig, *,
               contact_mm: float, limit_s: float) -> tuple[float, float]:
    """(heel strike, toe off) of one contact by distance from the rest points (see the module docstring):
    the first time heel or toe comes within ``contact_mm`` of where it rests, and the last time the toe is
    within ``toe_off_distance_mm`` of it. NaN where that crossing is not inside the data (or the window)."""
    times = tracks.times_s
    a, b = run
    d = contact_mm
    res = config.event_resolution_s
    lo = max(times[0], times[a] - config.event_window_s)
    grid = np.arange(lo, times[min(a + 2, b)] + res / 2, res)
    pts = tracks.sampler(grid)
    dist = np.minimum(np.linalg.norm(pts[:, HEEL[side]] - heel_mm, axis=1),
                      np.linalg.norm(pts[:, TOE[side]] - toe_mm, axis=1))
    hs = _first_below(grid, dist, d, int(np.searchsorted(grid, times[a])))
    if np.isnan(hs) and lo <= times[0] and dist[0] < d / 3:
        hs = -np.inf  # already at rest when the data start (closer, but farther than d/3: rolling in)
    hi = min(times[-1], times[b] + config.event_window_s, limit_s)
    grid = np.arange(times[max(b - 2, a)], hi + res / 2, res)
    dist = np.linalg.norm(tracks.sampler(grid)[:, TOE[side]] - toe_mm, axis=1)
    d = config.toe_off_distance_mm
    back = _first_below(grid[::-1], dist[::-1], d, len(grid) - 1 - int(np.searchsorted(grid, times[b])))
    if grid[-1] >= times[-1] - 1e-9 and dist[-1] < d:
        back = np.inf  # still on the floor when the data ends
    return hs, back


def _toe_behind(tracks: FootTracks, side: str, t_s: float, heel_mm, toe_mm, config: GaitConfig) -> float:
    """Time (s) within ``toe_off_window_s`` of ``t_s`` when the toe is farthest behind the body centre
    along the foot's own direction (heel to toe at rest); NaN when that is at the window's edge (no
    clear extremum) or the window leaves the data."""
    if not np.isfinite(t_s):
        return float("nan")
    w = config.toe_off_window_s
    lo, hi = t_s - w, t_s + w
    if lo < tracks.times_s[0] or hi > tracks.times_s[-1]:
        return float("nan")
    fwd = np.asarray(toe_mm[:2]) - np.asarray(heel_mm[:2])
    fwd = fwd / max(float(np.linalg.norm(fwd)), 1e-9)
    grid = np.arange(lo, hi, config.event_resolution_s)
    pts = tracks.sampler(grid)
    ahead = (pts[:, TOE[side], :2] - pts[:, CENTER, :2]) @ fwd
    j = int(np.argmin(ahead))
    return float(grid[j]) if 0 < j < len(grid) - 1 else float("nan")


def _pitch_deg(heel_mm: np.ndarray, toe_mm: np.ndarray) -> np.ndarray:
    """Pitch (degrees, toe up positive) of the heel-to-toe line; (..., 3) -> (...)."""
    foot = np.asarray(toe_mm) - np.asarray(heel_mm)
    return np.degrees(np.arctan2(foot[..., 2], np.linalg.norm(foot[..., :2], axis=-1)))


def _height_noise_mm(z_mm: np.ndarray) -> float:
    """Noise (mm) of a point's height over a contact's frames (T,): 1.4826 x the median absolute second
    difference / sqrt(6) (white noise of SD s gives second differences of SD sqrt(6) s; a foot's own motion
    at rest adds little to them); inf with fewer than 3 frames."""
    z = np.asarray(z_mm, dtype=float)
    d2 = (z[:-2] - 2 * z[1:-1] + z[2:]) if len(z) >= 3 else np.zeros(0)
    d2 = d2[np.isfinite(d2)]
    return 1.4826 * float(np.median(np.abs(d2))) / np.sqrt(6.0) if len(d2) else float("inf")


def _heel_landing(tracks: FootTracks, side: str, t_s: float, heel_mm, toe_mm, config: GaitConfig, *,
                  height_noise_mm: float) -> float:
    """Time (s) of a heel-first landing's impact after ``t_s`` (the contact-distance crossing): the heel's
    lowest point within ``heel_landing_window_s`` after it (a heel lands near where it rests: a lowest point
    before the crossing is no landing), when the heel there is below its stance height by
    at least ``heel_landing_dip_mm`` and ``heel_landing_noise_factor`` x ``height_noise_mm`` (the noise of
    its height in the contact) and the foot pitched toe up by at least ``heel_landing_pitch_deg`` more than in
    stance, by enough to explain the dip (at most ``heel_landing_lever_mm`` x the sine of that pitch; see
    the module docstring); NaN otherwise (a flat or toe-first contact, a dip within the noise,
    no clear lowest point inside the window, the window outside the data)."""
    w = config.heel_landing_window_s
    if w <= 0 or not np.isfinite(t_s):
        return float("nan")
    grid = np.arange(t_s, min(t_s + w, tracks.times_s[-1]), config.event_resolution_s)
    if len(grid) < 3:
        return float("nan")
    pts = tracks.sampler(grid)
    heel, toe = pts[:, HEEL[side]], pts[:, TOE[side]]
    k = int(np.argmin(heel[:, 2]))
    if not 0 < k < len(grid) - 1:
        return float("nan")
    dip = float(heel_mm[2] - heel[k, 2])
    pitch = float(_pitch_deg(heel[k], toe[k]) - _pitch_deg(np.asarray(heel_mm), np.asarray(toe_mm)))
    least = max(config.heel_landing_dip_mm, config.heel_landing_noise_factor * height_noise_mm)
    lever = config.heel_landing_lever_mm * np.sin(np.radians(pitch))  # the dip the pitch can explain
    heel_first = least <= dip <= lever and pitch >= config.heel_landing_pitch_deg
    return float(grid[k]) if heel_first else float("nan")


def _event_times(tracks: FootTracks, side: str, runs, speed: np.ndarray, rest: np.ndarray, v_rest: float,
                 config: GaitConfig, rest_points, *, contact_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """(R,) heel strike and toe off times (s) of the runs (see the module docstring); NaN where the event
    is not inside the trial. The speed-threshold events are the fallback where the distance crossing is
    not found inside a run's window (a contact too short or too noisy for its rest point)."""
    times = tracks.times_s
    last, dt = len(times) - 1, float(np.median(np.diff(times)))
    h, t = HEEL[side], TOE[side]
    v_event = _event_speed(speed[:, h], speed[:, t], rest, v_rest, config)
    starts = np.array([[times[max(a - 3, 0)], times[min(a + 2, b)]] for a, b in runs if a > 0]).reshape(-1, 2)
    ends = np.array([[times[max(b - 2, a)], times[min(b + 3, last)]] for a, b in runs if b < last]).reshape(-1, 2)
    hs = _events(tracks, side, starts, v_event, falling=True, config=config, dt=dt)
    to = _events(tracks, side, ends, v_event, falling=False, config=config, dt=dt)
    if config.toe_off_peak_fraction > 0:
        next_start = [times[runs[k + 1][0]] if k + 1 < len(runs) else times[-1]
                      for k, (_, b) in enumerate(runs) if b < last]
        brisk = _departures(tracks, side, np.array([times[b] for _, b in runs if b < last]),
                            np.array(next_start), v_rest, config)
        to = np.where(np.isfinite(brisk), brisk, to)
    hs_all, to_all = np.full(len(runs), np.nan), np.full(len(runs), np.nan)
    hs_all[[i for i, (a, _) in enumerate(runs) if a > 0]] = hs
    to_all[[i for i, (_, b) in enumerate(runs) if b < last]] = to
    if config.contact_distance_mm <= 0:
        return hs_all, to_all
    for i, (run, (heel_mm, toe_mm)) in enumerate(zip(runs, rest_points, strict=True)):
        limit = times[runs[i + 1][0]] if i + 1 < len(runs) else times[-1]
        near_hs, near_to = _near_rest(tracks, side, run, heel_mm, toe_mm, config, contact_mm=contact_mm,
                                      limit_s=limit)
        at_start, at_end = run[0] == 0, run[1] == last
        # a foot near its rest point when the data start may still be rolling in after a contact just
        # before or inside the data (speed fallback); one within d/3 of it is at rest: no heel strike
        short = times[run[1]] - times[run[0]] + dt < config.min_stance_s  # kept only as cut by an end
        at_start |= short and run[0] < last - run[1]
        at_end |= short and run[0] >= last - run[1]
        hs_all[i] = near_hs if np.isfinite(near_hs) and not at_start else (
            np.nan if at_start or near_hs < 0 else hs_all[i])
        noise = _height_noise_mm(tracks.frames_mm[run[0]:run[1] + 1, h, 2])
        landing = _heel_landing(tracks, side, hs_all[i], heel_mm, toe_mm, config, height_noise_mm=noise)
        hs_all[i] = landing if np.isfinite(landing) else hs_all[i]
        if not np.isfinite(near_to) or (at_end and short):
            to_all[i] = np.nan if at_end or near_to > 0 else to_all[i]
            continue
        # toe off: the toe farthest behind the body centre (Zeni et al. 2008) near the toe leaving its
        # rest point, else midway between that and the brisk departure (see the module docstring)
        behind = _toe_behind(tracks, side, near_to, heel_mm, toe_mm, config)
        if np.isfinite(behind):
            to_all[i] = behind
        else:
            to_all[i] = near_to if not np.isfinite(to_all[i]) else 0.5 * (near_to + to_all[i])
    return hs_all, to_all


def _cut_at_start(tracks: FootTracks, side: str, runs, config: GaitConfig) -> list[tuple[int, int]]:
    """The end of a stance cut by the start of the recording when the speed test misses it (a toe rolling
    at the end of stance, a fit's wobble at the first frames): the toe on the floor (within
    ``max_contact_lift_mm`` / 4 of its stance height) at the first frame and within
    ``toe_off_distance_mm`` of where it is then for at least 2 frames, before any detected contact."""
    frames, times = tracks.frames_mm, tracks.times_s
    t = TOE[side]
    if runs and times[runs[0][0]] - times[0] < config.min_stance_s:
        return []
    z_toe = np.percentile(frames[tracks.valid[:, t], t, 2], 10)
    if frames[0, t, 2] - z_toe > config.max_contact_lift_mm / 4:
        return []
    near = np.linalg.norm(frames[:, t] - frames[0, t], axis=1) < config.toe_off_distance_mm
    j = int(np.argmin(near)) - 1 if not near.all() else len(times) - 1
    if j < 2 or (runs and j >= runs[0][0]):
        return []
    return [(0, j)]


def detect_contacts(tracks: FootTracks, walking_speed_mm_s: float,
                    config: GaitConfig = GaitConfig(), *, noise_mm_s: float | None = None) -> tuple[Contact, ...]:
    """All foot contacts of the trial, both feet, ordered by heel strike (see the module docstring).
    ``noise_mm_s``: the feet's speed noise at rest while walking (default ``tracks.rest_noise_mm_s()``)."""
    times, frames = tracks.times_s, tracks.frames_mm
    noise = tracks.rest_noise_mm_s() if noise_mm_s is None else noise_mm_s
    v_rest = rest_speed_mm_s(walking_speed_mm_s, config, noise)
    speed = tracks.speed_mm_s(times)
    dt = float(np.median(np.diff(times)))
    contacts: list[Contact] = []
    for side in SIDES:
        h, t = HEEL[side], TOE[side]
        runs, rest = _contact_runs(tracks, side, speed, v_rest, config)
        runs = _cut_at_start(tracks, side, runs, config) + runs
        points = [(_rest_point(frames[a:b + 1, h], speed[a:b + 1, h], v_rest),
                   _rest_point(frames[a:b + 1, t], speed[a:b + 1, t], v_rest)[0]) for a, b in runs]
        hs, to = _event_times(tracks, side, runs, speed, rest, v_rest, config,
                              [(heel, toe) for (heel, _), toe in points],
                              contact_mm=contact_distance(walking_speed_mm_s, config))
        for (a, b), t_hs, t_to, ((heel, spread), toe) in zip(runs, hs, to, points, strict=True):
            ok = bool(np.isfinite(t_hs) and tracks.is_valid(times[a] - 4 * dt, times[b] + 4 * dt, (h, t)))
            contacts.append(Contact(side, float(t_hs), float(t_to), tuple(map(float, heel)),
                                    tuple(map(float, toe)), spread, ok))
    order = np.argsort([c.heel_strike_s if np.isfinite(c.heel_strike_s) else -np.inf for c in contacts],
                       kind="stable")
    return tuple(contacts[i] for i in order)
