"""Explicit representation: the trajectory is a free (3, T, J) array of points in mm."""

from __future__ import annotations

from dataclasses import dataclass, field

import jax
import numpy as np
from gaitcap.reconstruction.fits.common import FitOutput, from_fit_layout, to_fit_layout
from gaitcap.reconstruction.fits.optim import LBFGS, Adam, Progress, Solver
from gaitcap.reconstruction.losses import LossConfig, Problem, total_loss


@dataclass(frozen=True)
class _PointsObjective:
    loss: LossConfig

    def __call__(self, points, problem: Problem, reg_scale):
        return total_loss(points, problem, self.loss, reg_scale)


@dataclass(frozen=True)
class ExplicitFit:
    """Optimise the points directly, starting from the (gap-filled) robust triangulation.

    Default: 150 L-BFGS iterations, Huber slope cut beyond 10 px, smoothness weight 0.3 (the paper: 0.1).
    :meth:`paper`: Adam at lr 0.1 (mm) with the regularisers switched on after 5000 steps, plain Huber.
    """

    solver: Solver = field(default_factory=lambda: LBFGS(iterations=150))
    loss: LossConfig = field(default_factory=lambda: LossConfig(cut_px=10.0, smooth_weight=0.3))

    @classmethod
    def paper(cls, steps: int = 50_000) -> ExplicitFit:
        solver = Adam(learning_rate=0.1, steps=steps, reg_start=steps // 10, chunk=500)
        return cls(solver=solver, loss=LossConfig())

    def fit(self, problem: Problem, init_mm: np.ndarray, times_s: np.ndarray, progress: Progress | None = None,
            *, joint_names: tuple[str, ...] = ()):
        """init_mm: (T, J, 3) NaN-free start (``joint_names``: unused, every point is free). Returns
        :class:`FitOutput`."""
        objective = _PointsObjective(self.loss)
        params, history = self.solver.minimize(objective, to_fit_layout(init_mm), problem, progress)
        _, parts = jax.jit(objective)(params, problem, 1.0)
        return FitOutput(from_fit_layout(params), history, {k: float(v) for k, v in parts.items()})
