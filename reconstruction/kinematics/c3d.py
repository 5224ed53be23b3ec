"""The contents of a C3D export as data: marker trajectories (mm, room frame, z up) and gait events.

Writing the binary file is the services' job (``gaitcap.services.kinematics.c3d_file``, with ezc3d).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.kinematics.cycles import StepEvent

EVENT_CONTEXTS = {"left": "Left", "right": "Right"}
EVENT_LABELS = {"heel_strike": "Foot Strike", "toe_off": "Foot Off"}  # the labels Vicon/Nexus use


@dataclass(frozen=True, eq=False)
class C3DContent:
    """labels (J,), points_mm (T, J, 3) room frame z up, NaN = gap; rate_hz; first_time_s; events as
    (context "Left"/"Right", label "Foot Strike"/"Foot Off", time s), sorted by time."""

    labels: tuple[str, ...]
    points_mm: np.ndarray
    rate_hz: float
    first_time_s: float
    events: tuple[tuple[str, str, float], ...]


def c3d_content(points_mm, times_s, joint_names, steps=()) -> C3DContent:
    """Build the C3D contents of a trial; ``steps``: the gait report's steps (objects or JSON dicts).
    ValueError naming the inconsistent input."""
    pts = np.asarray(points_mm, dtype=np.float64)
    t = np.asarray(times_s, dtype=np.float64).reshape(-1)
    names = tuple(str(n) for n in joint_names)
    if pts.ndim != 3 or pts.shape[-1] != 3 or pts.shape[1] != len(names):
        raise ValueError(f"points_mm: expected (T, {len(names)}, 3), got {pts.shape}")
    if pts.shape[0] != t.size or t.size < 2:
        raise ValueError(f"times_s: {t.size} times for {pts.shape[0]} frames (need at least 2)")
    rate = 1.0 / float(np.median(np.diff(t)))
    events = []
    for s in map(StepEvent.of, steps):
        for kind, time in (("heel_strike", s.heel_strike_s), ("toe_off", s.toe_off_s)):
            if np.isfinite(time) and t[0] <= time <= t[-1]:
                events.append((EVENT_CONTEXTS[s.foot], EVENT_LABELS[kind], float(time)))
    events = sorted(set(events), key=lambda e: (e[2], e[0], e[1]))
    return C3DContent(names, pts, rate, float(t[0]), tuple(events))
