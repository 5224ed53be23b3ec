"""A synthetic pressure-walkway (GaitRite-like) export generated from a synthetic trial's ground truth.

The walkway sees each straight-pass footfall from its heel strike to its toe off; its heel and toe points
lie ``pressure_offset_mm`` behind the visual heel and toe keypoints along the direction of progression
(the paper measured about 13 mm), in the walkway's own frame (x along the walkway, i.e. the first pass's
direction up to ``rotation_error_deg``, plus an unknown translation and a scale near 1) and clock
(``t_walkway = t_world - time_offset_s``), with small Gaussian noise on positions and times.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.gait.walkway import Similarity2D, WalkwayTrial


@dataclass(frozen=True)
class WalkwayExportParams:
    """How the synthetic walkway differs from the world (mm, s, deg); random parts drawn from ``seed``."""

    pressure_offset_mm: float = 13.0
    rotation_error_deg: float = 2.0
    translation_mm: float = 3000.0
    scale_range: tuple[float, float] = (0.986, 1.014)
    time_offset_range_s: tuple[float, float] = (-3.0, 3.0)
    position_noise_mm: float = 2.0
    time_noise_s: float = 0.004
    seed: int = 0


@dataclass(frozen=True, eq=False)
class WalkwayExport:
    """The export and the hidden truth needed to check an alignment.

    Attributes:
        trial: the walkway's footfalls (walkway frame and clock).
        transform: world xy (mm) -> walkway xy (mm).
        time_offset_s: t_world = t_walkway + time_offset_s.
        step_rows: (N,) row of each footfall in the ground-truth step table.
    """

    trial: WalkwayTrial
    transform: Similarity2D
    time_offset_s: float
    step_rows: np.ndarray


def make_walkway_export(steps, *, name: str = "0", params: WalkwayExportParams = WalkwayExportParams(),
                        transform: Similarity2D | None = None) -> WalkwayExport:
    """Walkway export of the straight-pass footfalls of a ground-truth step table (``GaitTruth.steps``:
    foot, heel_strike_s, toe_off_s, heel_mm, toe_mm, pass_index, direction).

    ``transform`` (world xy -> walkway xy) fixes the walkway's placement, e.g. to share it between the
    trials of one session; by default it is drawn from ``params``.
    """
    rows = np.flatnonzero((np.asarray(steps.pass_index) >= 0) & np.isfinite(steps.toe_off_s)
                          & np.isfinite(steps.heel_strike_s))
    if len(rows) < 2:
        raise ValueError("walkway export: the trial has fewer than 2 straight-pass footfalls")
    rng = np.random.default_rng(params.seed)
    direction = np.asarray(steps.direction)[rows, :2]
    heading = math.atan2(direction[0, 1], direction[0, 0])
    rotation = -heading + math.radians(rng.uniform(-1, 1) * params.rotation_error_deg)
    drawn = Similarity2D(float(rng.uniform(*params.scale_range)), rotation,
                         tuple(float(v) for v in rng.uniform(-1, 1, 2) * params.translation_mm))
    transform = transform or drawn
    offset = float(rng.uniform(*params.time_offset_range_s))
    back = params.pressure_offset_mm * direction

    def noisy(xy):
        return transform.apply(xy) + rng.normal(0.0, params.position_noise_mm, xy.shape)

    heel = noisy(np.asarray(steps.heel_mm)[rows, :2] - back)
    toe = noisy(np.asarray(steps.toe_mm)[rows, :2] - back)
    first = np.asarray(steps.heel_strike_s)[rows] - offset + rng.normal(0, params.time_noise_s, len(rows))
    last = np.asarray(steps.toe_off_s)[rows] - offset + rng.normal(0, params.time_noise_s, len(rows))
    trial = WalkwayTrial(name, tuple(str(f) for f in np.asarray(steps.foot)[rows]), first, last, heel, toe)
    return WalkwayExport(trial, transform, offset, rows)
