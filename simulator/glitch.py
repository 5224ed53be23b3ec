"""A detector glitch that makes one impossible step: the tests' and benchmarks' walk with one bad footfall.

:class:`FootGlitch` names one footfall of one foot on a straight pass; the detector places that foot's
joints (ankle, heel, big and small toe) ``shift_mm`` across the walking direction, towards the other
foot, from the footfall's heel strike to its toe off, in every camera alike (so triangulation agrees on
the wrong place: no outlier rejection can see it). The ground truth is the real walk; only what the
cameras report is wrong. With the default 100 mm shift of a walker with 100 mm steps the glitched step's
width comes out near 0 mm among widths near 100 mm (the walk of the issue that asked for it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.skeletons import Skeleton

FOOT_JOINTS = ("ankle", "heel", "big_toe", "small_toe")


@dataclass(frozen=True)
class FootGlitch:
    """``foot`` ("left" | "right"); ``footfall``: which of that foot's footfalls on straight passes (0 =
    the first, time order); ``shift_mm``: how far across the walking direction, towards the other foot,
    its joints are seen (mm; negative: away from it)."""

    foot: str = "right"
    footfall: int = 4
    shift_mm: float = 100.0

    def __post_init__(self) -> None:
        if self.foot not in ("left", "right"):
            raise ValueError(f"FootGlitch.foot: 'left' or 'right', got {self.foot!r}")
        if isinstance(self.footfall, bool) or int(self.footfall) != self.footfall or self.footfall < 0:
            raise ValueError(f"FootGlitch.footfall: an integer >= 0, got {self.footfall!r}")
        if not np.isfinite(self.shift_mm):
            raise ValueError(f"FootGlitch.shift_mm: a finite number of mm, got {self.shift_mm!r}")


def glitched_span(glitch: FootGlitch, truth) -> tuple[float, float, np.ndarray]:
    """(heel strike s, toe off s, (2,) horizontal unit shift direction) of the glitched footfall in the
    ground truth's steps (a ``GaitTruth``). ValueError when the walk has fewer such footfalls."""
    st = truth.steps
    rows = np.flatnonzero((st.foot == glitch.foot) & st.straight)
    if glitch.footfall >= len(rows):
        raise ValueError(f"FootGlitch.footfall {glitch.footfall}: the walk has only {len(rows)} {glitch.foot} "
                         "footfalls on straight passes")
    i = int(rows[glitch.footfall])
    d = np.asarray(st.direction[i][:2], dtype=np.float64)
    d /= np.linalg.norm(d)
    left_normal = np.array([-d[1], d[0]])
    towards_other = left_normal if glitch.foot == "right" else -left_normal
    return float(st.heel_strike_s[i]), float(st.toe_off_s[i]), towards_other


def glitched_points(points_mm: np.ndarray, times_s: np.ndarray, skeleton: Skeleton, glitch: FootGlitch,
                    truth) -> np.ndarray:
    """``points_mm`` (T, J, 3) as the glitching detector sees them: the glitched foot's joints moved
    ``glitch.shift_mm`` towards the other foot over its footfall (see the module docstring)."""
    start, end, towards = glitched_span(glitch, truth)
    out = np.array(points_mm, dtype=np.float64, copy=True)
    frames = (times_s >= start) & (times_s <= end)
    joints = [skeleton.index(f"{glitch.foot}_{j}") for j in FOOT_JOINTS if f"{glitch.foot}_{j}" in skeleton.joint_names]
    for j in joints:
        out[frames, j, :2] += glitch.shift_mm * towards
    return out
