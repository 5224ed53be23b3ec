"""An analytic walker for the gait tests: feet flat in stance, swings with a brisk push-off and a landing
like a real one along a path: at initial contact the foot still moves forward (at 2 ROLL_MM / LOAD_S,
0.9 m/s) and comes to rest ROLL_MM further on after LOAD_S (the heel rocker; real heels travel 20-40 mm
after contact, see simulator/foot.py)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

JOINTS = ("left_hip", "right_hip", "left_ankle", "right_ankle", "left_heel", "right_heel",
          "left_big_toe", "right_big_toe")
FOOT_MM = 230.0
ROLL_MM = 35.0
LOAD_S = 0.08


@dataclass
class Walk:
    times_s: np.ndarray
    points_mm: np.ndarray  # (T, 8, 3)
    joint_names: tuple[str, ...]
    feet: list[str]
    hs_s: np.ndarray
    to_s: np.ndarray
    heels_mm: np.ndarray  # (K, 2)
    arc_mm: np.ndarray  # (K,) arc length of each contact along the path
    sample: object


def _path(segments, heading_deg):
    """Dense (N, 2) polyline at 1 mm spacing and its unit tangents from ("line", L) / ("arc", r, deg)."""
    pts, tangents = [np.zeros(2)], []
    th = np.radians(heading_deg)
    for seg in segments:
        if seg[0] == "line":
            n = int(seg[1])
            for _ in range(n):
                tangents.append((np.cos(th), np.sin(th)))
                pts.append(pts[-1] + tangents[-1])
        else:
            r, ang = seg[1], np.radians(seg[2])
            n = int(abs(ang) * r)
            for _ in range(n):
                th += ang / n
                tangents.append((np.cos(th), np.sin(th)))
                pts.append(pts[-1] + np.array(tangents[-1]) * abs(ang) * r / n)
    tangents.append(tangents[-1])
    return np.array(pts), np.array(tangents)


def _swing(tau, end_slope=0.0):
    """Swing progress 0 -> 1: speed ~ tau (1 - tau)^2 (a brisk push-off), plus end_slope tau^2 (tau - 1)
    so that the foot lands with speed end_slope x distance / swing time."""
    tau = np.clip(tau, 0.0, 1.0)
    return 6 * tau**2 - 8 * tau**3 + 3 * tau**4 + end_slope * tau**2 * (tau - 1)


def make_walk(*, segments=(("line", 6000),), heading_deg=30.0, step_mm=650.0, width_mm=140.0,
              step_time_s=0.55, duty=0.62, fps=30.0, stand_s=1.0, end_stand_s=1.0, lift_mm=60.0):
    path, tangent = _path(segments, heading_deg)
    normal = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)  # left of the direction of travel
    n_contacts = int((len(path) - 1) // step_mm) + 1
    arc = np.arange(n_contacts) * step_mm
    feet = ["left" if k % 2 == 0 else "right" for k in range(n_contacts)]
    side = np.where(np.array(feet) == "left", 1.0, -1.0)
    idx = np.minimum(arc.astype(int), len(path) - 1)
    heels = path[idx] + (side * width_mm / 2)[:, None] * normal[idx]
    heading = tangent[idx]
    hs = stand_s + (np.arange(n_contacts) - 1) * step_time_s
    to = hs + duty * 2 * step_time_s
    hs[:2] = -np.inf  # both feet are standing when the trial starts
    to[-2:] = np.inf  # and again at the end
    t_end = stand_s + (n_contacts - 2) * step_time_s + end_stand_s

    def sample(t):
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        out = np.zeros((len(t), len(JOINTS), 3))
        for f, foot in enumerate(("left", "right")):
            ks = np.flatnonzero(np.array(feet) == foot)
            heel = np.zeros((len(t), 3))
            head = np.zeros((len(t), 2))
            for a, b in zip(ks[:-1], ks[1:], strict=True):
                swing = (t >= to[a]) & (t < hs[b])
                tau = (t[swing] - to[a]) / (hs[b] - to[a])
                land = heels[b] - ROLL_MM * heading[b]
                span = np.linalg.norm(land - heels[a])
                s = _swing(tau, 2 * ROLL_MM / LOAD_S * (hs[b] - to[a]) / span)[:, None]
                heel[swing, :2] = heels[a] + s * (land - heels[a])
                heel[swing, 2] = lift_mm * np.sin(np.pi * np.clip(tau, 0, 1)) ** 2
                hv = heading[a] + s * (heading[b] - heading[a])
                head[swing] = hv / np.linalg.norm(hv, axis=1, keepdims=True)
            for k in ks:
                stance = (t >= hs[k]) & (t <= to[k])
                heel[stance, :2] = heels[k]
                loading = stance & (t < hs[k] + LOAD_S)
                rolled = ROLL_MM * (1 - (t[loading] - hs[k]) / LOAD_S) ** 2
                heel[loading, :2] = heels[k] - rolled[:, None] * heading[k]
                heel[stance, 2] = 0.0
                head[stance] = heading[k]
            out[:, 4 + f] = heel + [0, 0, 40.0]
            out[:, 6 + f, :2] = heel[:, :2] + FOOT_MM * head
            out[:, 6 + f, 2] = heel[:, 2] + 20.0
            out[:, 2 + f] = heel + [0, 0, 90.0]
        # Body centre: moves along the path at the mean speed between the first and last swing.
        s_c = np.interp(t, [stand_s, t_end - end_stand_s], [arc[0] + step_mm / 2, arc[-1] - step_mm / 2])
        ci = np.clip(s_c.astype(int), 0, len(path) - 1)
        for f, sgn in ((0, 1.0), (1, -1.0)):
            out[:, f, :2] = path[ci] + sgn * 100.0 * normal[ci]
            out[:, f, 2] = 900.0
        return out

    times = np.arange(0.0, t_end, 1.0 / fps)
    return Walk(times, sample(times), JOINTS, feet, hs, to, heels, arc, sample)


@pytest.fixture
def walker():
    return make_walk
