"""Board views that disagree with the other cameras as a whole, decided per frame set.

A view is a candidate when most of its corners are outliers of the bundle adjustment (median error over
the outlier threshold), yet its own board pose (PnP, :func:`solve_view`) explains its corners about as
well as a typical view's corners are explained: noisy corners do not fit a pose of their own. Which view
of the frame set is wrong is then decided by the OTHER cameras: the board pose is fitted to their corners
alone (the rig held as the bundle adjustment left it, as :mod:`refit` does). The candidate is left out
only when at least two other cameras saw the frame set, each of them fits that pose (median error within
the outlier threshold) and the candidate does not. A frame set seen by only two cameras, or whose other
cameras disagree among themselves, cannot say which view is wrong: the candidate is kept and counted as
undecidable. So is a view in a frame set shared with a camera refused on every view (the RMS
rule on the first bundle adjustment) that has no view of its own to leave out: a camera wrong throughout
(late, wrong focal length) bends the rig, and the other cameras' views then disagree through no fault
of their own.

At most :data:`MAX_LEFT_OUT_FRACTION` of a camera's views as found (before pairing or readout removed
any) are left out; a camera with more keeps them all and is judged on them (a camera whose views mostly
disagree is wrong, not unlucky).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from gaitcap.reconstruction.calibration.bundle import (
    BundleConfig,
    BundleProblem,
    BundleResult,
    BundleState,
    bundle_adjust,
    outlier_threshold_px,
)
from gaitcap.reconstruction.calibration.intrinsics import Intrinsics
from gaitcap.reconstruction.calibration.views import solve_view

MAX_LEFT_OUT_FRACTION = 1 / 3  # of a camera's views as found
SELF_FIT_FACTOR = 2.0  # a view agrees with itself when its own pose's median error is within this x typical
MIN_CORNERS = 4  # a view's own pose needs this many corners
MIN_OTHER_CAMERAS = 2  # cameras that must agree on a frame set's board pose to single out a view

LEFT_OUT_REASON = "its corners fit a board pose of their own but not the pose the other cameras saw"


@dataclass(frozen=True, eq=False)
class WholeViews:
    """left_out (P,) bool: corners of the views left out; per camera (C,): views left out and views that
    disagreed as a whole in a frame set that could not say which camera was wrong (kept, judged)."""

    left_out: np.ndarray
    views_left_out: np.ndarray
    views_undecidable: np.ndarray


@dataclass(frozen=True)
class _Views:
    """The bundle problem's views: view key (cam * F + frame) and the rows of each, sorted by key."""

    keys: np.ndarray
    rows: list[np.ndarray]


def _views(prob: BundleProblem) -> _Views:
    key = prob.cam.astype(np.int64) * prob.num_frames + prob.frame
    order = np.argsort(key, kind="stable")
    keys, starts = np.unique(key[order], return_index=True)
    return _Views(keys, np.split(order, starts[1:]))


def _own_fit_median_px(prob: BundleProblem, res: BundleResult, rows: np.ndarray) -> float:
    """Median error (px) of a view's corners under the board pose fitted to that view alone."""
    c = int(prob.cam[rows[0]])
    intr = Intrinsics(res.state.matrix_px[c], res.state.dist[c], float("nan"))
    obj = prob.object_points_mm[prob.corner[rows]].astype(np.float64)
    _, _, median = solve_view(obj, prob.uv_px[rows].astype(np.float64), intr)
    return median


def _candidates(prob: BundleProblem, res: BundleResult, views: _Views, threshold: float) -> list[int]:
    """Indices into ``views`` of the views disagreeing as a whole yet fitting a pose of their own."""
    err = np.linalg.norm(res.residual_px, axis=-1)
    typical = float(np.median(err[res.inlier]))
    out = []
    for k, rows in enumerate(views.rows):
        if len(rows) < MIN_CORNERS or np.median(err[rows]) <= threshold:
            continue
        if _own_fit_median_px(prob, res, rows) <= SELF_FIT_FACTOR * typical:
            out.append(k)
    return out


def _others_fit(prob: BundleProblem, res: BundleResult, views: _Views, picks: list[int],
                config: BundleConfig) -> tuple[np.ndarray, list[np.ndarray]]:
    """For each picked view, the board pose fitted to the other cameras of its frame set alone (one
    problem, a frame per pick, cameras and intrinsics held): the picked view's median error (px) under it,
    and each other camera's median error (px) (the picked view's corners excluded from the fit)."""
    cam, frame, corner, uv, mine = [], [], [], [], []
    for j, k in enumerate(picks):
        f = int(views.keys[k] % prob.num_frames)
        rows = np.flatnonzero(prob.frame == f)
        cam.append(prob.cam[rows])
        frame.append(np.full(len(rows), j))
        corner.append(prob.corner[rows])
        uv.append(prob.uv_px[rows])
        mine.append(prob.cam[rows] == views.keys[k] // prob.num_frames)
    sub = BundleProblem(np.concatenate(cam), np.concatenate(frame), np.concatenate(corner), np.concatenate(uv),
                        prob.object_points_mm, prob.num_cameras, len(picks), prob.root, prob.free_dist,
                        prob.held_principal_point)
    frames = (views.keys[picks] % prob.num_frames).astype(int)
    s = res.state
    state = BundleState(s.matrix_px, s.dist, s.cam_rotation, s.cam_tvec_mm, s.frame_rotation[frames],
                        s.frame_tvec_mm[frames])
    held = replace(config, refine_intrinsics=False, refine_cameras=False)
    mine = np.concatenate(mine)
    fit = bundle_adjust(sub, state, held, exclude=mine)
    err = np.linalg.norm(fit.residual_px, axis=-1)
    own, others = np.zeros(len(picks)), []
    for j, k in enumerate(picks):
        rows = sub.frame == j
        own[j] = np.median(err[rows & mine])
        cams = [c for c in np.unique(sub.cam[rows]) if c != views.keys[k] // prob.num_frames]
        others.append(np.array([np.median(err[rows & (sub.cam == c)]) for c in cams]))
    return own, others


def disagreeing_views(prob: BundleProblem, res: BundleResult, config: BundleConfig, *,
                      views_found: np.ndarray, refused: np.ndarray) -> WholeViews:
    """The views to leave out (see the module docstring); ``views_found`` (C,): each camera's views as
    the detector gave them, the cap's base; ``refused`` (C,) bool: cameras the RMS rule refuses on every
    view (a refused camera with no view of its own to leave out bends the rig: other cameras' views in
    the frame sets it shares are kept, counted undecidable)."""
    err = np.linalg.norm(res.residual_px, axis=-1)
    threshold = outlier_threshold_px(err[res.inlier], config)
    views = _views(prob)
    frame_of, cam_of = views.keys % prob.num_frames, views.keys // prob.num_frames
    cams_of = np.bincount(frame_of, minlength=prob.num_frames)  # cameras seeing each frame set
    cand = _candidates(prob, res, views, threshold)
    picks = [k for k in cand if cams_of[frame_of[k]] - 1 >= MIN_OTHER_CAMERAS]
    undecidable = np.bincount(cam_of[sorted(set(cand) - set(picks))], minlength=prob.num_cameras)
    wrong: dict[int, list[int]] = {}
    if picks:
        own, others = _others_fit(prob, res, views, picks, config)
        for k, own_px, others_px in zip(picks, own, others, strict=True):
            if not np.all(others_px <= threshold):
                undecidable[cam_of[k]] += 1  # the other cameras disagree among themselves
            elif own_px > threshold:  # they agree on a pose, and this view does not fit it
                wrong.setdefault(int(cam_of[k]), []).append(k)
    wrong = {c: ks for c, ks in wrong.items() if len(ks) <= MAX_LEFT_OUT_FRACTION * views_found[c]}
    bending = {int(c) for c in np.flatnonzero(refused)} - set(wrong)
    drop = np.zeros(len(prob.cam), dtype=bool)
    n_left = np.zeros(prob.num_cameras, dtype=int)
    for c, ks in wrong.items():
        for k in ks:
            if set(cam_of[frame_of == frame_of[k]].tolist()) & (bending - {c}):
                undecidable[c] += 1
                continue
            n_left[c] += 1
            drop[views.rows[k]] = True
    return WholeViews(drop, n_left, undecidable)
