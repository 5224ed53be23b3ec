"""Gross keypoint outliers before a model fit: a keypoint that is far from where the rest of the body puts
it (a wrong match triangulated from two views, another person's keypoint) pulls the model's segment after
it. Pure numpy."""

from __future__ import annotations

import warnings

import numpy as np

OUTLIER_MM = 400.0  # beyond any arm swing or knee bend: a wrist's distance from the hips varies by ~250 mm


def gross_outliers(points_mm: np.ndarray, names, *, centre: tuple[str, str],
                   limit_mm: float = OUTLIER_MM) -> np.ndarray:
    """(T, M) bool: frames where a keypoint's distance from the centre of two keypoints (e.g. both hips)
    differs from that distance's median over the trial by more than ``limit_mm`` (mm). ``points_mm``
    (T, M, 3) with NaN for missing; ValueError naming a missing centre keypoint."""
    names = [str(n) for n in names]
    missing = [c for c in centre if c not in names]
    if missing:
        raise ValueError(f"names: no {', '.join(missing)} to measure outliers from")
    pts = np.asarray(points_mm, dtype=np.float64)
    mid = 0.5 * (pts[:, names.index(centre[0])] + pts[:, names.index(centre[1])])
    dist = np.linalg.norm(pts - mid[:, None], axis=-1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a keypoint missing in every frame: median NaN
        typical = np.nanmedian(dist, axis=0)
    return np.isfinite(dist) & (np.abs(dist - typical) > limit_mm)
