"""Board views that disagree with the other cameras as a whole: most of the view's corners are outliers
of the bundle adjustment, yet the view agrees with itself (its own board pose explains its corners about
as well as a typical view's corners are explained). That is a board seen at another moment than the
other cameras saw it (moving during a rolling-shutter readout, or frames out of sync), not a noisy
camera: noisy corners do not fit their own pose either. Such views are left out and counted, at most
:data:`MAX_LEFT_OUT_FRACTION` of a camera's views; a camera with more keeps them all and is judged on
them (a camera whose views mostly disagree is wrong, not unlucky)."""

from __future__ import annotations

import numpy as np
from gaitcap.reconstruction.calibration.bundle import (
    BundleConfig,
    BundleProblem,
    BundleResult,
    outlier_threshold_px,
)
from gaitcap.reconstruction.calibration.intrinsics import Intrinsics
from gaitcap.reconstruction.calibration.views import solve_view

MAX_LEFT_OUT_FRACTION = 1 / 3  # of a camera's views
SELF_FIT_FACTOR = 2.0  # a view agrees with itself when its own pose's median error is within this x typical
MIN_CORNERS = 4  # a view's own pose needs this many corners

LEFT_OUT_REASON = "the board disagreed with the other cameras as a whole (moving or out of sync)"


def _own_fit_median_px(prob: BundleProblem, res: BundleResult, rows: np.ndarray) -> float:
    """Median error (px) of a view's corners under the board pose fitted to that view alone."""
    c = int(prob.cam[rows[0]])
    intr = Intrinsics(res.state.matrix_px[c], res.state.dist[c], float("nan"))
    obj = prob.object_points_mm[prob.corner[rows]].astype(np.float64)
    _, _, median = solve_view(obj, prob.uv_px[rows].astype(np.float64), intr)
    return median


def disagreeing_views(prob: BundleProblem, res: BundleResult, config: BundleConfig) -> np.ndarray:
    """(P,) bool: the corners of the views to leave out (see the module docstring)."""
    err = np.linalg.norm(res.residual_px, axis=-1)
    threshold = outlier_threshold_px(err[res.inlier], config)
    typical = float(np.median(err[res.inlier]))
    view = prob.cam.astype(np.int64) * prob.num_frames + prob.frame
    order = np.argsort(view, kind="stable")
    views, starts = np.unique(view[order], return_index=True)
    rows_of = np.split(order, starts[1:])  # the rows of each view, in ``views`` order
    drop = np.zeros(len(prob.cam), dtype=bool)
    for c in range(prob.num_cameras):
        mine = np.flatnonzero(views // prob.num_frames == c)
        found = [k for k in mine if _disagrees(prob, res, rows_of[k], err, threshold, typical)]
        if found and len(found) <= MAX_LEFT_OUT_FRACTION * len(mine):
            for k in found:
                drop[rows_of[k]] = True
    return drop


def _disagrees(prob, res, rows: np.ndarray, err: np.ndarray, threshold: float, typical: float) -> bool:
    if len(rows) < MIN_CORNERS or np.median(err[rows]) <= threshold:
        return False
    return _own_fit_median_px(prob, res, rows) <= SELF_FIT_FACTOR * typical
