"""The room and the footstep plan: where and when each foot lands.

The room is the paper's (7.4 m x 8 m), world origin at its centre on the floor, x along the 7.4 m wall,
y along the 8 m wall, z up. The patient walks the diagonal from corner A = (-3.7, -4.0) m towards
corner B = (3.7, 4.0) m and back, turning left (180 degrees, ``turn_steps`` steps on a circle of
``turn_radius_mm``) at each end, so the outward and return passes run ``turn_radius_mm`` either side of
the diagonal. The walk starts and ends standing with the feet side by side.

A plan is a list of :class:`Contact` (one per foot placement, strictly alternating feet), each with its
event times: heel strike (HS), foot flat (FF), heel rise (HR) and toe-off (TO). Between HS and HR the heel
keypoint is exactly stationary on its contact point; between FF and TO the big toe is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from gaitcap.simulator.params import WalkParams

ROOM_SIZE_MM = (7400.0, 8000.0)
LEFT, RIGHT = +1, -1
SIDE_NAME = {LEFT: "left", RIGHT: "right"}
SIDE_OF = {"left": LEFT, "right": RIGHT}

# Tempo of the non-steady steps relative to the steady step time.
TEMPO = {"stand": 1.0, "start": 1.15, "steady": 1.0, "turn": 1.25, "stop": 1.15, "follow": 1.0}
FOOT_FLAT_FRACTION = 0.08  # of the stride time, HS -> FF
HEEL_RISE_FRACTION = 0.22  # of the stride time, HR -> TO


@dataclass(frozen=True)
class Room:
    size_mm: tuple[float, float] = ROOM_SIZE_MM

    @property
    def half(self) -> np.ndarray:
        return np.array(self.size_mm) / 2

    @property
    def corner_a(self) -> np.ndarray:
        return -self.half

    @property
    def corner_b(self) -> np.ndarray:
        return self.half

    @property
    def diagonal_mm(self) -> float:
        return float(np.linalg.norm(self.corner_b - self.corner_a))

    def contains(self, xy: np.ndarray, margin_mm: float = 0.0) -> np.ndarray:
        xy = np.asarray(xy)
        return np.all(np.abs(xy) <= self.half - margin_mm, axis=-1)


def left_normal(heading: float) -> np.ndarray:
    return np.array([-math.sin(heading), math.cos(heading)])


def forward(heading: float) -> np.ndarray:
    return np.array([math.cos(heading), math.sin(heading)])


def wrap_angle(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


@dataclass
class Contact:
    """One foot placement.

    side: +1 left, -1 right. heel_xy: the stationary heel point (mm). heading: foot direction (rad).
    kind: "stand" (initial standing placement, no heel strike), "start", "steady", "turn", "stop",
    "follow" (a companion's steps). pass_index: the straight pass (line) it lies on, or -1.
    line_heading: the pass direction when on a pass line (else the foot heading).
    Times (s): t_hs, t_ff (-inf for standing placements), t_hr, t_to (+inf when the foot never leaves).
    """

    side: int
    heel_xy: np.ndarray
    heading: float
    kind: str
    pass_index: int = -1
    line_heading: float = 0.0
    tempo: float = 1.0
    t_hs: float = -math.inf
    t_ff: float = -math.inf
    t_hr: float = math.inf
    t_to: float = math.inf


@dataclass
class FootPlan:
    contacts: list[Contact]
    walk_start_s: float  # heel rise of the first stepping foot
    walk_end_s: float  # foot flat of the last placement
    duration_s: float
    stride_time_s: float
    pass_lines: list[tuple[np.ndarray, float]] = field(default_factory=list)  # (origin xy, heading)

    def by_side(self, side: int) -> list[Contact]:
        return [c for c in self.contacts if c.side == side]

    @property
    def steps(self) -> list[Contact]:
        """The placements that start with a heel strike (everything but the initial standing)."""
        return [c for c in self.contacts if c.kind != "stand"]


class _Builder:
    """Accumulates alternating contacts and their heel-strike times."""

    def __init__(self, params: WalkParams):
        self.p = params
        self.T = params.stride_time_s
        self.contacts: list[Contact] = []
        # steady step time of each landing side, and the double-support time
        self.ds = self.T * (params.stance_fraction - 0.5)
        self.step_time = {
            s: self.ds + self.T * (1.0 - params.side_stance_fraction(SIDE_NAME[s])) for s in (LEFT, RIGHT)
        }
        self.step_len = {s: params.side_step_length_mm(SIDE_NAME[s]) for s in (LEFT, RIGHT)}

    def add(self, side, heel_xy, heading, kind, pass_index=-1, line_heading=None) -> Contact:
        c = Contact(
            side=side, heel_xy=np.asarray(heel_xy, dtype=float), heading=float(heading), kind=kind,
            pass_index=pass_index, line_heading=float(heading if line_heading is None else line_heading),
            tempo=TEMPO[kind],
        )
        if self.contacts:
            assert self.contacts[-1].side == -side, "contacts must alternate feet"
        self.contacts.append(c)
        return c


def _heel_on_line(origin, heading, p, side, width):
    return origin + p * forward(heading) + side * (width / 2) * left_normal(heading)


def _build_patient(
    params: WalkParams, room: Room, n_passes: int, pass_len: float, stand_start: float, seed: int = 0
) -> _Builder:
    b = _Builder(params)
    rng = np.random.default_rng([int(seed), 59])
    sd_l, sd_w = params.step_length_sd_mm, params.step_width_sd_mm

    def jitter(heel, heading):
        if sd_l == 0 and sd_w == 0:
            return heel
        return heel + rng.normal(0, sd_l) * forward(heading) + rng.normal(0, sd_w) * left_normal(heading)

    a, bb = room.corner_a, room.corner_b
    d = (bb - a) / np.linalg.norm(bb - a)
    heading0 = math.atan2(d[1], d[0])
    r, w = params.turn_radius_mm, params.step_width_mm
    origin = a + params.walkway_margin_mm * d - r * left_normal(heading0)
    heading = heading0
    lead = SIDE_OF[params.lead_foot]
    b.add(lead, _heel_on_line(origin, heading, 0.0, lead, w), heading, "stand", 0, heading)
    b.add(-lead, _heel_on_line(origin, heading, 0.0, -lead, w), heading, "stand", 0, heading)
    lines = [(origin.copy(), heading)]
    for j in range(n_passes):
        p = 0.0
        side = -b.contacts[-1].side
        # two starting steps (half step, then full) then steady steps while they fit in the pass
        p += 0.5 * b.step_len[side]
        b.add(side, _heel_on_line(origin, heading, p, side, w), heading, "start", j, heading)
        side = -side
        p += b.step_len[side]
        b.add(side, _heel_on_line(origin, heading, p, side, w), heading, "start", j, heading)
        side = -side
        while p + b.step_len[side] <= pass_len:
            p += b.step_len[side]
            b.add(side, jitter(_heel_on_line(origin, heading, p, side, w), heading), heading, "steady", j, heading)
            side = -side
        if j == n_passes - 1:
            # closing step: bring the other foot side by side and stop
            b.add(side, _heel_on_line(origin, heading, p, side, w), heading, "stop", j, heading)
            break
        # turn left 180 degrees around a pivot r to the left of the current centre
        centre = origin + p * forward(heading)
        pivot = centre + r * left_normal(heading)
        n_t = int(params.turn_steps)
        for i in range(1, n_t + 1):
            th = heading + i * math.pi / n_t
            e = pivot - r * left_normal(th)
            b.add(side, e + side * (w / 2) * left_normal(th), th, "turn")
            side = -side
        heading = heading + math.pi
        origin = pivot - r * left_normal(heading)
        lines.append((origin.copy(), heading))
        # the last turn placement lies on the new line at p = 0
        last = b.contacts[-1]
        last.pass_index, last.line_heading = j + 1, heading
    b.lines = lines
    _assign_times(b, stand_start, rng if params.step_time_sd_s > 0 else None)
    return b


def _assign_times(b: _Builder, stand_start: float, rng: np.random.Generator | None = None) -> None:
    """Heel-strike times and the FF/HR/TO events of every contact (contacts alternate feet)."""
    cs = b.contacts
    T = b.T
    ff, hr = FOOT_FLAT_FRACTION * T, HEEL_RISE_FRACTION * T
    n_stand = sum(c.kind == "stand" for c in cs)
    assert n_stand == 2 and cs[0].kind == cs[1].kind == "stand"
    if len(cs) == 2:
        return
    first = cs[2]
    # the first stepping foot (contact 0) rises at stand_start and toes off hr later
    cs[0].t_hr = stand_start
    cs[0].t_to = stand_start + hr
    swing0 = first.tempo * (b.step_time[first.side] - b.ds)
    t = cs[0].t_to + swing0
    for k in range(2, len(cs)):
        c = cs[k]
        if k > 2:
            dt = c.tempo * b.step_time[c.side]
            if rng is not None:
                dt += float(np.clip(rng.normal(0, b.p.step_time_sd_s), -0.1 * dt, 0.1 * dt))
            t += dt
        c.t_hs = t
        c.t_ff = t + ff * c.tempo
    for k in range(1, len(cs)):
        c = cs[k]
        if k + 2 < len(cs):
            nxt = cs[k + 1]
            c.t_to = nxt.t_hs + nxt.tempo * b.ds
            c.t_hr = c.t_to - hr * nxt.tempo
    for c in cs:
        if c.t_hr < c.t_ff:
            raise AssertionError("gait timing: heel rise before foot flat")


def _plan_end(b: _Builder) -> float:
    last = b.contacts[-1]
    return last.t_ff if math.isfinite(last.t_ff) else 0.0


def plan_walk(params: WalkParams, seconds: float, room: Room | None = None, seed: int = 0) -> FootPlan:
    """Plan the patient's walk: as many full passes of the diagonal as fit in ``seconds``.

    Extra time is split between the standing phases. Raises ValueError when not even a short pass fits.
    """
    room = room or Room()
    pass_len = room.diagonal_mm - 2 * params.walkway_margin_mm
    if pass_len < 3 * params.step_length_mm:
        raise ValueError(
            f"walkway_margin_mm={params.walkway_margin_mm} leaves a {pass_len:.0f} mm walkway: too short for "
            f"steps of {params.step_length_mm} mm"
        )
    stand0, stand1 = params.stand_start_s, params.stand_end_s
    for attempt in range(2):
        try:
            return _plan_walk(params, seconds, room, pass_len, stand0, stand1, seed)
        except ValueError:
            if attempt == 1 or (stand0 <= 0.3 and stand1 <= 0.3):
                raise
            # short clips: shorten the standing phases before giving up
            stand0, stand1 = min(stand0, 0.3), min(stand1, 0.3)
    raise AssertionError("unreachable")


def _plan_walk(
    params: WalkParams, seconds: float, room: Room, pass_len: float, stand0: float, stand1: float, seed: int
) -> FootPlan:
    budget = seconds - stand0 - stand1

    def walk_time(n, length):
        bld = _build_patient(params, room, n, length, 0.0, seed)
        return bld, _plan_end(bld)

    chosen = None
    n = 1
    while True:
        bld, dur = walk_time(n, pass_len)
        if dur > budget:
            break
        chosen = (n, pass_len, dur)
        n += 1
    if chosen is None:
        length = pass_len
        min_len = 2.5 * params.step_length_mm
        while length > min_len:
            length = max(min_len, length * 0.9)
            bld, dur = walk_time(1, length)
            if dur <= budget:
                chosen = (1, length, dur)
                break
        if chosen is None:
            _, dur = walk_time(1, min_len)
            need = dur + stand0 + stand1
            raise ValueError(
                f"seconds={seconds:g} is too short for a walk with these parameters: need at least {math.ceil(need * 10) / 10:g} s"
            )
    n, length, dur = chosen
    extra = budget - dur
    stand_start = stand0 + extra / 2
    bld = _build_patient(params, room, n, length, stand_start, seed)
    return FootPlan(
        contacts=bld.contacts,
        walk_start_s=stand_start,
        walk_end_s=_plan_end(bld),
        duration_s=float(seconds),
        stride_time_s=bld.T,
        pass_lines=bld.lines,
    )


def plan_from_guide(
    params: WalkParams,
    guide_times: np.ndarray,
    guide_xy: np.ndarray,
    guide_heading: np.ndarray,
    moving: np.ndarray,
    seconds: float,
    phase_s: float = 0.0,
) -> FootPlan:
    """A companion's footsteps: follow a guide path (pelvis positions over time) at its own cadence.

    ``moving`` (T,) bool marks when the guide walks; footsteps are placed where the guide will be half a
    step later, so the pelvis (interpolated from the feet) follows the guide.
    """
    b = _Builder(params)
    w = params.step_width_mm
    T = b.T
    t_step = T / 2

    def guide_at(t):
        x = np.interp(t, guide_times, guide_xy[:, 0])
        y = np.interp(t, guide_times, guide_xy[:, 1])
        h = np.interp(t, guide_times, np.unwrap(guide_heading))
        return np.array([x, y]), float(h)

    idx = np.flatnonzero(moving)
    foot_back = 0.5 * (params.foot_mm or 0.14 * params.height_mm)
    xy0, h0 = guide_at(guide_times[0])
    lead = SIDE_OF[params.lead_foot]
    heel0 = lambda xy, h, s: xy - foot_back * forward(h) + s * (w / 2) * left_normal(h)  # noqa: E731
    b.add(lead, heel0(xy0, h0, lead), h0, "stand")
    b.add(-lead, heel0(xy0, h0, -lead), h0, "stand")
    if idx.size == 0:
        plan = FootPlan(b.contacts, math.inf, 0.0, seconds, T)
        return plan
    t_start = float(guide_times[idx[0]]) + phase_s
    t_stop = float(guide_times[idx[-1]])
    # heel-strike times at a steady rhythm while the guide moves
    hs_times = []
    t = t_start + HEEL_RISE_FRACTION * T + (t_step - b.ds)
    while t < t_stop + 0.5 * t_step:
        hs_times.append(t)
        t += t_step
    side = -lead
    xy_first, h_first = guide_at(t_start)
    b.contacts[0].heel_xy = heel0(xy_first, h_first, lead)
    b.contacts[1].heel_xy = heel0(xy_first, h_first, -lead)
    b.contacts[0].heading = b.contacts[1].heading = h_first
    side = lead
    for t in hs_times:
        xy, h = guide_at(t + 0.5 * t_step)
        b.add(side, heel0(xy, h, side), h, "follow")
        side = -side
    # closing step: side by side with the last one
    last = b.contacts[-1]
    b.add(side, last.heel_xy + side * w * left_normal(last.heading), last.heading, "stop")
    _assign_times(b, t_start)
    return FootPlan(b.contacts, t_start, _plan_end(b), seconds, T)


def plan_standing(params: WalkParams, xy: np.ndarray, heading: float, seconds: float) -> FootPlan:
    """A person standing still at ``xy`` facing ``heading``."""
    b = _Builder(params)
    foot_back = 0.5 * (params.foot_mm or 0.14 * params.height_mm)
    w = params.step_width_mm
    for s in (LEFT, RIGHT):
        b.add(s, np.asarray(xy) - foot_back * forward(heading) + s * (w / 2) * left_normal(heading), heading, "stand")
    return FootPlan(b.contacts, math.inf, 0.0, seconds, b.T)
