"""Per-contact confidence from the reconstruction's quality and the stillness of the heel in stance."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.gait.config import GaitConfig


@dataclass(frozen=True, eq=False)
class TrajectoryQuality:
    """Optional per-frame, per-joint quality of a reconstruction (same T and J as ``points_mm``).

    Attributes:
        num_views: (T, J) number of cameras that contributed to each point (>= 0).
        reprojection_px: (T, J) mean reprojection error of each point (px); NaN when unknown.
    """

    num_views: np.ndarray
    reprojection_px: np.ndarray

    def __post_init__(self) -> None:
        views = np.asarray(self.num_views, dtype=np.float64)
        reproj = np.asarray(self.reprojection_px, dtype=np.float64)
        if views.ndim != 2 or reproj.shape != views.shape:
            raise ValueError(f"quality: num_views {views.shape} and reprojection_px {reproj.shape} must "
                             "both be (T, J)")
        object.__setattr__(self, "num_views", views)
        object.__setattr__(self, "reprojection_px", reproj)


def contact_confidence(
    *,
    heel_spread_mm: float,
    frames: slice,
    joints: list[int],
    quality: TrajectoryQuality | None,
    config: GaitConfig,
) -> float:
    """Confidence in [0, 1] of one contact.

    Product of exp(-heel spread / stance_spread_scale_mm) (a reconstructed heel that wanders during
    stance is unreliable) and, when quality is given, min(1, median views / full_confidence_views) and
    exp(-median reprojection px / reprojection_scale_px) over the heel and toe during the contact.
    """
    conf = float(np.exp(-heel_spread_mm / max(config.stance_spread_scale_mm, 1e-9)))
    if quality is None:
        return conf
    views = quality.num_views[frames][:, joints]
    reproj = quality.reprojection_px[frames][:, joints]
    if views.size == 0:
        return 0.0
    conf *= min(1.0, float(np.median(views)) / max(config.full_confidence_views, 1))
    if np.isfinite(reproj).any():
        conf *= float(np.exp(-np.nanmedian(reproj) / max(config.reprojection_scale_px, 1e-9)))
    return conf
