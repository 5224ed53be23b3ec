"""Reconstruction methods as typed configs, and the one public entry :func:`reconstruct`.

Each method is a small frozen dataclass with ``run(detections, rig, progress) -> Reconstruction``:

- :class:`DLT`: confidence-weighted DLT per frame (baseline).
- :class:`Robust`: the paper's robust triangulation per frame.
- :class:`Explicit`: robust triangulation, then the points optimised on the paper's loss (L-BFGS).
- :class:`Implicit` (default): robust triangulation, then a time function fitted on the paper's loss
  (cubic B-splines + L-BFGS by default; ``Implicit.paper()`` is the paper's MLP and schedule).

``METHODS`` maps CLI names to classes.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field, replace

import numpy as np
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.fits.common import fill_gaps, fit_problem, reject_spikes
from gaitcap.reconstruction.fits.explicit import ExplicitFit
from gaitcap.reconstruction.fits.implicit import ImplicitFit
from gaitcap.reconstruction.fits.memory import check_memory, fit_bytes, triangulation_bytes
from gaitcap.reconstruction.fits.optim import Progress
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.metrics import compute_metrics, reprojection_errors_px
from gaitcap.reconstruction.result import Reconstruction
from gaitcap.reconstruction.triangulation import dlt_triangulate, robust_triangulate

log = logging.getLogger(__name__)

FIT_WEIGHT_SCALE_PX = 20.0  # reported view weights after a fit: exp(-reprojection px / 20) x confidence


def _from_triangulation(name: str, tri: Reconstruction, seconds: float) -> Reconstruction:
    return replace(tri, method=name, losses={"seconds": seconds})


class _TriangulationMethod:
    """Shared by the per-frame methods: ``self.triangulate``, timed, as a Reconstruction."""

    def memory_bytes(self, detections: MultiViewKeypoints) -> int:
        """Estimated peak memory of the reconstruction, bytes."""
        c, t, _, j = detections.shape
        return triangulation_bytes(c, t, j)

    def run(self, detections: MultiViewKeypoints, rig: Rig, progress: Progress | None = None) -> Reconstruction:
        t0 = time.perf_counter()
        tri = self.triangulate(detections, rig)
        return _from_triangulation(self.name, tri, time.perf_counter() - t0)


@dataclass(frozen=True)
class DLT(_TriangulationMethod):
    """Confidence-weighted DLT; views with confidence <= ``min_confidence`` are unused."""

    min_confidence: float = 0.0
    name = "dlt"

    def triangulate(self, detections: MultiViewKeypoints, rig: Rig) -> Reconstruction:
        return dlt_triangulate(detections, rig, min_confidence=self.min_confidence)


@dataclass(frozen=True)
class Robust(_TriangulationMethod):
    """The paper's robust triangulation (gamma: confidence threshold; sigma_mm: pair-weight scale)."""

    gamma: float = 0.5
    sigma_mm: float = 150.0
    name = "robust"

    def triangulate(self, detections: MultiViewKeypoints, rig: Rig) -> Reconstruction:
        return robust_triangulate(detections, rig, gamma=self.gamma, sigma_mm=self.sigma_mm)


def _run_fit(name, fit, robust: Robust, use_confidence: bool, det: MultiViewKeypoints, rig: Rig, progress):
    """Robust triangulation -> gap-filled start -> fit -> Reconstruction (with reported view weights)."""
    t0 = time.perf_counter()
    if det.shape[1] < 2:
        raise ValueError(f"times_s: a trajectory fit needs at least 2 frames, got {det.shape[1]}")
    tri = robust.triangulate(det, rig)
    conf = np.nan_to_num(det.one_person[..., 2])
    weights = conf if use_confidence else tri.camera_weights
    problem = fit_problem(det, rig, weights, gamma=robust.gamma)
    init = fill_gaps(reject_spikes(tri.points_mm), det.times_s, det.skeleton.joint_names)
    out = fit.fit(problem, init, det.times_s, progress, joint_names=tuple(det.skeleton.joint_names))
    err = np.nan_to_num(reprojection_errors_px(out.points_mm, det, rig), nan=np.inf)
    view_w = np.exp(-err / FIT_WEIGHT_SCALE_PX) * conf
    losses = dict(out.parts, steps=len(out.history), seconds=time.perf_counter() - t0)
    return Reconstruction(
        method=name, points_mm=out.points_mm, times_s=det.times_s, joint_names=det.skeleton.joint_names,
        camera_names=det.camera_names, camera_weights=view_w, quality=view_w.sum(0), losses=losses,
        trajectory=out.trajectory,
    )


class _FitMethod:
    """Shared by the trajectory fits: robust triangulation, then ``self.fit`` on the paper's loss."""

    def run(self, detections: MultiViewKeypoints, rig: Rig, progress: Progress | None = None) -> Reconstruction:
        return _run_fit(self.name, self.fit, self.robust, self.use_confidence, detections, rig, progress)

    def memory_bytes(self, detections: MultiViewKeypoints) -> int:
        """Estimated peak memory of the reconstruction, bytes (the time model's arrays included)."""
        c, t, _, j = detections.shape
        model = getattr(self.fit, "model", None)
        extra = model.model_bytes(t, _duration_s(detections), j) if model is not None else 0
        return fit_bytes(c, t, j, extra)


def _duration_s(detections: MultiViewKeypoints) -> float:
    times = detections.times_s
    return float(times[-1] - times[0]) if len(times) > 1 else 0.0


@dataclass(frozen=True)
class Explicit(_FitMethod):
    """Explicit trajectory fit (default: L-BFGS; :meth:`paper`: Adam lr 0.1, 50k steps).

    ``use_confidence``: weight the reprojection term by keypoint confidences (default) instead of the
    robust triangulation's camera weights (the paper's main configuration, used by :meth:`paper`).
    """

    fit: ExplicitFit = field(default_factory=ExplicitFit)
    robust: Robust = field(default_factory=Robust)
    use_confidence: bool = True
    name = "explicit"

    @classmethod
    def paper(cls, steps: int = 50_000) -> Explicit:
        return cls(fit=ExplicitFit.paper(steps), use_confidence=False)


@dataclass(frozen=True)
class Implicit(_FitMethod):
    """Implicit trajectory fit (default: cubic B-spline time model; :meth:`paper`: the paper's MLP)."""

    fit: ImplicitFit = field(default_factory=ImplicitFit)
    robust: Robust = field(default_factory=Robust)
    use_confidence: bool = True
    name = "implicit"

    @classmethod
    def paper(cls, steps: int = 50_000) -> Implicit:
        return cls(fit=ImplicitFit.paper(steps), use_confidence=False)


Method = DLT | Robust | Explicit | Implicit
METHODS: dict[str, type] = {cls.name: cls for cls in (DLT, Robust, Explicit, Implicit)}


def reconstruct(
    detections: MultiViewKeypoints,
    rig: Rig,
    *,
    method: Method | None = None,
    truth_mm: np.ndarray | None = None,
    progress: Progress | None = None,
) -> Reconstruction:
    """Reconstruct one person's trajectory and compute its metrics.

    Args:
        detections: keypoints (C, T, J, 3); cameras matched to ``rig`` by name.
        rig: the calibration (may hold more cameras than the detections).
        method: a method config (default :class:`Implicit`).
        truth_mm: optional ground truth (T, J, 3) mm for MPJPE and heel/toe errors.
        progress: optional callback (steps done, steps total) for fits.

    Raises:
        TrialTooLarge (a ValueError): the method's estimated peak memory for this trial exceeds the
            memory available, checked before any work starts; the message gives both.
    """
    method = Implicit() if method is None else method
    if not hasattr(method, "run"):
        raise ValueError(f"method: expected one of {sorted(METHODS)} configs, got {method!r}")
    c, t, _, j = detections.shape
    check_memory(method.memory_bytes(detections), what=(
        f"reconstructing {_duration_s(detections):.0f} s ({t} frames x {c} cameras x {j} joints) with the "
        f"{method.name} method"))
    rec = method.run(detections, rig, progress)
    metrics = compute_metrics(rec.points_mm, detections, rig, truth_mm=truth_mm)
    log.info("%s: %s", rec.method, {k: v for k, v in metrics.items() if not isinstance(v, dict)})
    return Reconstruction(**{**rec.__dict__, "metrics": metrics})
