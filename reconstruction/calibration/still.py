"""Still board scenes: runs of frames in which the board does not move, merged into one frame each.

A board lying still on the floor is filmed for many frames, but a detector's errors on a still image
repeat in every frame; kept apart, such a run would weigh as many independent views and pull the
bundle adjustment towards its repeated errors. A run is merged into one frame with every camera's
corners averaged.

Real detections make this harder than comparing arrays: a camera may miss the board in some frames of
the run, another may only see it in a few, and an orientation-blind detector (plain checkerboard) may
report the same still board in a different corner order from one frame to the next. So a frame joins
the current run when every camera that saw the board in both the run's first view (its reference) and
this frame saw it in the same place (median corner shift), up to one of the board's symmetries, and at least one camera could
be compared. Frames where no camera sees the board join the run they fall in (they add nothing).
"""

from __future__ import annotations

import numpy as np
from gaitcap.reconstruction.calibration.geometry import BoardObservations

MIN_COMMON_CORNERS = 4  # corners two views must share to be compared


def align_view(view_px: np.ndarray, ref_px: np.ndarray, symmetries: np.ndarray, tol_px: float) -> np.ndarray | None:
    """``view_px`` (N, 2) reordered by the board symmetry that puts it on ``ref_px`` (N, 2), or None when
    no symmetry does (the board moved). The median shift of the shared corners must stay below ``tol_px``:
    a detector's corners on small, oblique views jitter by a pixel or more now and then, while a moving
    board shifts all of them."""
    candidates = view_px[symmetries]  # (S, N, 2): candidate s puts view corner symmetries[s][i] at slot i
    with np.errstate(invalid="ignore"):
        dev = np.abs(candidates - ref_px).max(-1)  # (S, N), NaN where either misses the corner
    common = np.isfinite(dev).sum(-1)
    if common.max() < MIN_COMMON_CORNERS:
        return None
    shift = np.array([np.median(d[np.isfinite(d)]) if n >= MIN_COMMON_CORNERS else np.inf
                      for d, n in zip(dev, common, strict=True)])
    best = int(np.argmin(shift))
    return candidates[best] if shift[best] < tol_px else None


def _join(frame_px: np.ndarray, ref_px: np.ndarray, usable: np.ndarray, ref_usable: np.ndarray,
          symmetries: np.ndarray, tol_px: float) -> np.ndarray | None:
    """Frame (C, N, 2) aligned to the run's reference views, or None when it does not belong to the run."""
    aligned = frame_px.copy()
    compared = 0
    for c in np.flatnonzero(usable & ref_usable):
        view = align_view(frame_px[c], ref_px[c], symmetries, tol_px)
        if view is None:
            return None
        aligned[c], compared = view, compared + 1
    return aligned if compared or not usable.any() else None


def still_runs(obs: BoardObservations, *, tol_px: float = 0.5) -> tuple[list[int], np.ndarray]:
    """First frame of every run, and the corners (C, F, N, 2) with each view put in its run reference's
    corner order."""
    corners, views = obs.corners_px, obs.views()
    syms = np.asarray(obs.board.symmetries)
    aligned = corners.copy()
    starts = [0]
    ref, ref_usable = corners[:, 0].copy(), views[:, 0].copy()
    for f in range(1, obs.shape[1]):
        joined = _join(corners[:, f], ref, views[:, f], ref_usable, syms, tol_px)
        if joined is None:
            starts.append(f)
            ref, ref_usable = corners[:, f].copy(), views[:, f].copy()
            continue
        aligned[:, f] = joined
        new = views[:, f] & ~ref_usable  # cameras that see the still board only from now on
        ref[new], ref_usable[new] = joined[new], True
    return starts, aligned


def merge_still_frames(obs: BoardObservations, *, tol_px: float = 0.5) -> tuple[BoardObservations, np.ndarray]:
    """Merge every still run into one frame (corners averaged per camera, in one order). Returns the
    merged observations and (F',) the first frame of each run."""
    starts, aligned = still_runs(obs, tol_px=tol_px)
    bounds = list(zip(starts, [*starts[1:], obs.shape[1]], strict=True))
    usable = obs.views()[..., None, None]
    aligned = np.where(usable, aligned, np.nan)  # views too small to use do not join the average
    merged = np.full((obs.shape[0], len(bounds), obs.shape[2], 2), np.nan)
    for i, (a, b) in enumerate(bounds):
        run = aligned[:, a:b]
        count = np.isfinite(run).sum(1)
        total = np.nansum(run, axis=1)
        merged[:, i] = np.where(count > 0, total / np.maximum(count, 1), np.nan)
    times = obs.times_s[np.array(starts)]
    merged_obs = BoardObservations(obs.camera_names, obs.image_sizes_px, merged, obs.board, times)
    return merged_obs, np.array(starts)
