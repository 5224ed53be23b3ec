"""The paper's quality metrics of a reconstruction (NumPy; NaN points allowed).

- GC_d: fraction of keypoints with confidence > 0.5 (on the joints OpenPose BODY_25 also has) whose
  reconstruction reprojects within d px (d = 5, 10, 20); a NaN point counts as a miss.
- L_reproj (Huber, px), L_smooth (mm/frame), L_skeleton (mm): the loss terms of
  :mod:`gaitcap.reconstruction.losses` evaluated with binary confidence weights (> gamma), same for every method.
- Per-camera reprojection error: median px over that camera's confident keypoints.
- Against ground truth when known: MPJPE (mm, mean over finite points), heel and toe errors (mm), and
  the fraction of points that are NaN.
"""

from __future__ import annotations

import warnings

import numpy as np
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.losses import LossConfig

GC_THRESHOLDS_PX = (5, 10, 20)
CONFIDENT = 0.5


def reprojection_errors_px(points_mm: np.ndarray, detections: MultiViewKeypoints, rig: Rig) -> np.ndarray:
    """(C, T, J) px distance between the reprojected points (T, J, 3) and the detections (NaN-aware)."""
    sub = rig.subset(detections.camera_names)
    proj = sub.project(points_mm)  # (C, T, J, 2)
    return np.linalg.norm(proj - detections.one_person[..., :2], axis=-1)


def geometric_consistency(err_px: np.ndarray, detections: MultiViewKeypoints, *, threshold: float = CONFIDENT):
    """{"GC_5": ..., "GC_10": ..., "GC_20": ...} on the OpenPose-body joints."""
    body = list(detections.skeleton.openpose_body_indices) or list(range(detections.shape[3]))
    conf = np.nan_to_num(detections.one_person[..., 2])[..., body]
    e = np.where(np.isfinite(err_px[..., body]), err_px[..., body], np.inf)
    sel = conf > threshold
    n = max(int(sel.sum()), 1)
    return {f"GC_{d}": float(((e <= d) & sel).sum() / n) for d in GC_THRESHOLDS_PX}


def huber_np(d_px: np.ndarray, cfg: LossConfig) -> np.ndarray:
    delta = cfg.huber_delta_px
    out = np.where(d_px <= delta, 0.5 * d_px**2, delta * (d_px - 0.5 * delta))
    if cfg.cut_px is not None:
        at_cut = delta * (cfg.cut_px - 0.5 * delta)
        out = np.where(d_px > cfg.cut_px, at_cut + cfg.cut_factor * delta * (d_px - cfg.cut_px), out)
    return out


def reprojection_loss_np(err_px, detections: MultiViewKeypoints, *, gamma: float = CONFIDENT, cfg=LossConfig()):
    """Mean Huber over confident keypoints with a finite reconstruction."""
    sel = (np.nan_to_num(detections.one_person[..., 2]) > gamma) & np.isfinite(err_px)
    return float(huber_np(err_px[sel], cfg).mean()) if sel.any() else float("nan")


def smooth_loss_np(points_mm: np.ndarray) -> float:
    """Mean per-frame displacement (mm/frame) over finite consecutive pairs."""
    d = np.linalg.norm(np.diff(points_mm, axis=0), axis=-1)
    return float(np.nanmean(d)) if np.isfinite(d).any() else float("nan")


def skeleton_loss_np(points_mm: np.ndarray, limbs) -> float:
    """sqrt(mean over limbs of the variance over time of the limb length), mm (NaN frames skipped)."""
    if not len(limbs):
        return 0.0
    a, b = np.array(limbs).T
    lengths = np.linalg.norm(points_mm[:, a] - points_mm[:, b], axis=-1)  # (T, L)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # limbs never reconstructed
        var = np.nanvar(lengths, axis=0)
    return float(np.sqrt(np.nanmean(var))) if np.isfinite(var).any() else float("nan")


def per_camera_error_px(err_px: np.ndarray, detections: MultiViewKeypoints, *, threshold: float = CONFIDENT):
    conf = np.nan_to_num(detections.one_person[..., 2])
    out = {}
    for c, name in enumerate(detections.camera_names):
        e = err_px[c][(conf[c] > threshold) & np.isfinite(err_px[c])]
        out[name] = float(np.median(e)) if e.size else float("nan")
    return out


def ground_truth_errors(points_mm: np.ndarray, truth_mm: np.ndarray, joint_names) -> dict[str, float]:
    """MPJPE, heel and toe errors (mm, over finite points) and the NaN fraction."""
    if truth_mm.shape != points_mm.shape:
        raise ValueError(f"ground truth: shape {truth_mm.shape} does not match points {points_mm.shape}")
    err = np.linalg.norm(points_mm - truth_mm, axis=-1)  # (T, J)

    def mean_of(names):
        idx = [joint_names.index(n) for n in names if n in joint_names]
        e = err[:, idx]
        return float(np.nanmean(e)) if idx and np.isfinite(e).any() else float("nan")

    return {
        "MPJPE": float(np.nanmean(err)) if np.isfinite(err).any() else float("nan"),
        "heel_error": mean_of(("left_heel", "right_heel")),
        "toe_error": mean_of(("left_big_toe", "right_big_toe")),
        "nan_fraction": float(np.mean(~np.isfinite(err))),
    }


def compute_metrics(
    points_mm: np.ndarray, detections: MultiViewKeypoints, rig: Rig, *, truth_mm: np.ndarray | None = None
) -> dict:
    """All metrics as a flat JSON-friendly dict (per-camera errors under "camera_error_px")."""
    err = reprojection_errors_px(points_mm, detections, rig)
    out = geometric_consistency(err, detections)
    out["L_reproj"] = reprojection_loss_np(err, detections)
    out["L_smooth"] = smooth_loss_np(points_mm)
    out["L_skeleton"] = skeleton_loss_np(points_mm, detections.skeleton.limb_indices)
    out["camera_error_px"] = per_camera_error_px(err, detections)
    if truth_mm is not None:
        out.update(ground_truth_errors(points_mm, np.asarray(truth_mm, dtype=np.float64),
                                       list(detections.skeleton.joint_names)))
    return out
