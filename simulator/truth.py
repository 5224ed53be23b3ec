"""Ground-truth gait events and spatial step parameters of a synthetic walk.

Definitions (shared with the gait analysis, which computes the same quantities from trajectories):
- heel strike: initial contact, the first instant the foot touches the floor (the foot is still moving then
  and rolls to rest at foot flat, see ``foot``); toe off: the last instant of contact;
- heel position of a contact: the stationary heel keypoint during stance (from foot flat to heel rise);
  toe position: the stationary big-toe keypoint (from foot flat to toe-off);
- step length: this heel minus the previous contralateral heel, projected on the direction of progression;
- stride length: this heel minus the previous ipsilateral heel, projected on the direction of progression;
- step width: perpendicular distance from this heel to the line through the contralateral heels just
  before and just after it (the walkway's "base of support"); NaN when there is no contralateral contact
  after it;
- direction of progression: the pass direction on straight passes, the foot heading elsewhere.
Steps of straight passes get their pass index (0, 1, ...); steps while starting, turning or stopping get
-1 and are excluded from straight-walk parameters. The initial standing placements are not steps but do
serve as the previous contacts of the first steps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from gaitcap.simulator.path import SIDE_NAME, FootPlan
from gaitcap.simulator.walker import Body


@dataclass(frozen=True, eq=False)
class StepTable:
    """One row per heel strike (S steps), time ordered."""

    foot: np.ndarray  # (S,) str "left"/"right"
    heel_strike_s: np.ndarray  # (S,)
    toe_off_s: np.ndarray  # (S,) toe-off that ends this contact (inf if the foot never leaves)
    heel_mm: np.ndarray  # (S, 3)
    toe_mm: np.ndarray  # (S, 3)
    step_length_mm: np.ndarray  # (S,)
    stride_length_mm: np.ndarray  # (S,)
    step_width_mm: np.ndarray  # (S,)
    pass_index: np.ndarray  # (S,) int, -1 outside straight passes
    direction: np.ndarray  # (S, 3) unit direction of progression
    kind: np.ndarray  # (S,) str: start / steady / turn / stop / follow

    def __len__(self) -> int:
        return int(self.heel_strike_s.shape[0])

    @property
    def straight(self) -> np.ndarray:
        return self.pass_index >= 0

    def as_dict(self) -> dict[str, np.ndarray]:
        return {
            "step_foot": self.foot, "step_heel_strike_s": self.heel_strike_s, "step_toe_off_s": self.toe_off_s,
            "step_heel_mm": self.heel_mm, "step_toe_mm": self.toe_mm, "step_length_mm": self.step_length_mm,
            "stride_length_mm": self.stride_length_mm, "step_width_mm": self.step_width_mm,
            "step_pass": self.pass_index, "step_direction": self.direction, "step_kind": self.kind,
        }


@dataclass(frozen=True, eq=False)
class GaitTruth:
    """Gait events per foot and the step table.

    heel_strike_s / toe_off_s: {"left": (n,) s, "right": (n,) s}, sorted, within the trial.
    """

    heel_strike_s: dict[str, np.ndarray]
    toe_off_s: dict[str, np.ndarray]
    steps: StepTable

    def summary(self) -> dict[str, float]:
        """Straight-pass means: step count, step length/width (mm), cadence (steps/min), speed (m/s)."""
        st = self.steps
        m = st.straight
        n_all = len(st)
        out = {"steps": float(n_all), "straight_steps": float(m.sum())}
        if m.sum() >= 1:
            out["step_length_mm"] = float(np.nanmean(st.step_length_mm[m]))
            out["stride_length_mm"] = float(np.nanmean(st.stride_length_mm[m]))
            out["step_width_mm"] = float(np.nanmean(st.step_width_mm[m]))
        # cadence from consecutive straight heel strikes within a pass
        dts = []
        for p in np.unique(st.pass_index[m]):
            t = np.sort(st.heel_strike_s[st.pass_index == p])
            if t.size >= 2:
                dts.extend(np.diff(t))
        if dts:
            out["cadence_spm"] = 60.0 / float(np.mean(dts))
            if "step_length_mm" in out:
                out["speed_m_s"] = out["step_length_mm"] / 1000.0 * out["cadence_spm"] / 60.0
        return out


def _toe_xyz(c, body: Body) -> np.ndarray:
    local = body.foot_points(c.side)[2]
    ca, sa = math.cos(c.heading), math.sin(c.heading)
    return np.array([
        c.heel_xy[0] + ca * local[0] - sa * local[1],
        c.heel_xy[1] + sa * local[0] + ca * local[1],
        body.heel_height + local[2],
    ])


def gait_truth(plan: FootPlan, body: Body, duration_s: float | None = None) -> GaitTruth:
    cs = plan.contacts
    dur = plan.duration_s if duration_s is None else duration_s
    hs = {"left": [], "right": []}
    to = {"left": [], "right": []}
    for c in cs:
        name = SIDE_NAME[c.side]
        if c.kind != "stand" and 0 <= c.t_hs <= dur:
            hs[name].append(c.t_hs)
        if math.isfinite(c.t_to) and 0 <= c.t_to <= dur:
            to[name].append(c.t_to)
    rows = []
    for k, c in enumerate(cs):
        if c.kind == "stand":
            continue
        d2 = np.array([math.cos(c.line_heading), math.sin(c.line_heading)])
        prev_c = cs[k - 1] if k >= 1 else None
        prev_i = cs[k - 2] if k >= 2 else None
        nxt = cs[k + 1] if k + 1 < len(cs) else None
        step = float((c.heel_xy - prev_c.heel_xy) @ d2) if prev_c is not None else math.nan
        stride = float((c.heel_xy - prev_i.heel_xy) @ d2) if prev_i is not None else math.nan
        width = math.nan
        if prev_c is not None and nxt is not None:
            a, b = prev_c.heel_xy, nxt.heel_xy
            ab = b - a
            n = float(np.linalg.norm(ab))
            if n > 1.0:
                width = abs(float(ab[0] * (c.heel_xy - a)[1] - ab[1] * (c.heel_xy - a)[0])) / n
        straight = c.kind == "steady" and nxt is not None and nxt.pass_index == c.pass_index
        rows.append((
            SIDE_NAME[c.side], c.t_hs, c.t_to, np.array([*c.heel_xy, body.heel_height]), _toe_xyz(c, body),
            step, stride, width, c.pass_index if straight else -1, np.array([*d2, 0.0]), c.kind,
        ))
    if rows:
        cols = list(zip(*rows, strict=True))
    else:
        cols = [[] for _ in range(11)]
    table = StepTable(
        foot=np.array(cols[0], dtype=str), heel_strike_s=np.array(cols[1], float),
        toe_off_s=np.array(cols[2], float),
        heel_mm=np.array(cols[3], float).reshape(-1, 3), toe_mm=np.array(cols[4], float).reshape(-1, 3),
        step_length_mm=np.array(cols[5], float), stride_length_mm=np.array(cols[6], float),
        step_width_mm=np.array(cols[7], float), pass_index=np.array(cols[8], int),
        direction=np.array(cols[9], float).reshape(-1, 3), kind=np.array(cols[10], dtype=str),
    )
    return GaitTruth(
        heel_strike_s={k: np.array(sorted(v)) for k, v in hs.items()},
        toe_off_s={k: np.array(sorted(v)) for k, v in to.items()},
        steps=table,
    )
