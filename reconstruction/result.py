"""The one trajectory type: the result of a reconstruction, of any method, as every stage, file reader and
viewer uses it (its file: :func:`gaitcap.services.processing.outputs.write_npz`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True, eq=False)
class Reconstruction:
    """One person's 3D trajectory.

    Attributes:
        method: name of the method that made it ("robust", "implicit", ...).
        points_mm: (T, J, 3) mm; NaN where a triangulation had fewer than 2 usable views.
        times_s: (T,) s.
        joint_names: (J,) names (skeleton order).
        camera_names: (C,) names (order of ``camera_weights``; empty when unknown).
        camera_weights: (C, T, J) weight of each view: robust-triangulation weights, or for fits
            exp(-reprojection px / 20) x confidence; None when unknown (a file, a chunked triangulation).
        quality: (T, J) effective number of agreeing views (sum of camera weights; 0 where NaN); None
            for a continuous result as the trial's stages keep it, whose points are samples of a function.
        losses: final loss terms of a fit ({} for triangulations), plus "steps" and "seconds".
        metrics: see :func:`gaitcap.reconstruction.metrics.compute_metrics`.
        trajectory: for continuous (implicit) results, times_s (K,) -> (K, J, 3) mm; None otherwise.
        elapsed_s: compute time of the stage that made it, s (0 when unknown).
    """

    method: str
    points_mm: np.ndarray
    times_s: np.ndarray
    joint_names: tuple[str, ...]
    camera_names: tuple[str, ...] = ()
    camera_weights: np.ndarray | None = None
    quality: np.ndarray | None = None
    losses: dict = field(default_factory=dict)
    metrics: dict = field(default_factory=dict)
    trajectory: Callable[[np.ndarray], np.ndarray] | None = None
    elapsed_s: float = 0.0

    def sample(self, times_s) -> np.ndarray:
        """Points (K, J, 3) mm at arbitrary times within the trial.

        Implicit results evaluate their fitted function; discrete results interpolate linearly between
        frames (NaN where either neighbour is NaN). Times outside the trial raise ValueError.
        """
        t = np.asarray(times_s, dtype=np.float64).reshape(-1)
        if self.trajectory is not None:
            return self.trajectory(t)
        lo, hi = self.times_s[0], self.times_s[-1]
        if t.size and (np.nanmin(t) < lo - 1e-6 or np.nanmax(t) > hi + 1e-6 or not np.isfinite(t).all()):
            raise ValueError(f"times_s: outside the trial [{lo:.4f}, {hi:.4f}] s")
        idx = np.clip(np.searchsorted(self.times_s, t, side="right") - 1, 0, len(self.times_s) - 1)
        nxt = np.minimum(idx + 1, len(self.times_s) - 1)
        span = np.where(nxt > idx, self.times_s[nxt] - self.times_s[idx], 1.0)
        a = ((t - self.times_s[idx]) / span)[:, None, None]
        return (1 - a) * self.points_mm[idx] + a * self.points_mm[nxt]
