"""The steps of one trial's computation: the patient (:func:`patient_input`), the layout
(:func:`resolve_layout`), a trajectory (:func:`preliminary`, :func:`refined` or :func:`trajectory_of`),
gait (:func:`gait_of`). They are sequenced in one place only, the one processing path
:func:`gaitcap.services.processing.trial.process_trial`, which every consumer of a trial calls.

Pure computation over ``gaitcap.acquisition.recording`` (reader) and ``reconstruction`` (maths); files are
written by :mod:`gaitcap.services.processing.outputs`. Robust triangulation is run on detections padded to a
fixed-size chunks of frames (the last one padded) so a warm worker never recompiles JAX for a new
trial length.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
from gaitcap.acquisition.readers import load_rig
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.result import Reconstruction

log = logging.getLogger(__name__)
FRAME_CHUNK = 256  # robust triangulation runs on chunks of this many frames: one compiled shape


def recorded_rig(mcap_path: Path, *, fallback_calibration: Path | None = None) -> Rig:
    """The calibration recorded in the MCAP, else ``fallback_calibration`` (TOML/JSON)."""
    from gaitcap.acquisition.recording.reader import read_calibration

    try:
        return read_calibration(mcap_path)
    except (ValueError, KeyError) as exc:
        if fallback_calibration is None:
            raise ValueError(f"recording {mcap_path.name}: no calibration in it ({exc})") from None
        return load_rig(fallback_calibration)


def pad_detections(det: MultiViewKeypoints, num_frames: int) -> MultiViewKeypoints:
    """Append frames with no observations (confidence 0, NaN pixels) up to ``num_frames``."""
    c, t, _, j = det.shape
    if num_frames <= t:
        return det
    dt = float(np.median(np.diff(det.times_s))) if t > 1 else 1 / 30
    pad = np.full((c, num_frames - t, j, 3), np.nan)
    pad[..., 2] = 0.0
    times = np.concatenate([det.times_s, det.times_s[-1] + dt * np.arange(1, num_frames - t + 1)])
    return MultiViewKeypoints.of_one_person(np.concatenate([det.one_person, pad], axis=1), det.camera_names, times,
                                           det.skeleton)


def frame_chunks(det: MultiViewKeypoints, chunk: int = FRAME_CHUNK):
    """Yield (start, MultiViewKeypoints of ``chunk`` frames); the last chunk is padded with empty frames."""
    t = det.shape[1]
    for start in range(0, t, chunk):
        stop = min(start + chunk, t)
        yield start, pad_detections(det.frames(slice(start, stop)), chunk)


def preliminary(det: MultiViewKeypoints, rig: Rig) -> Reconstruction:
    """Robust triangulation (the paper's), chunk by chunk to reuse one compiled shape."""
    from gaitcap.reconstruction.triangulation import robust_triangulate

    t0 = time.perf_counter()
    c, t, _, j = det.shape
    points, views = np.full((t, j, 3), np.nan), np.zeros((t, j))
    for start, part in frame_chunks(det):
        result = robust_triangulate(part, rig)
        n = min(FRAME_CHUNK, t - start)
        points[start:start + n] = np.asarray(result.points_mm)[:n]
        views[start:start + n] = np.asarray(result.quality)[:n]
    return Reconstruction("robust triangulation", points, det.times_s, det.skeleton.joint_names,
                          camera_names=tuple(det.camera_names), quality=views, elapsed_s=time.perf_counter() - t0)


def refined(det: MultiViewKeypoints, rig: Rig, *, progress=None) -> Reconstruction:
    """The default implicit trajectory fit (continuous in time); ``progress(done, total)`` as it runs."""
    from gaitcap.reconstruction.methods import Implicit, reconstruct

    t0 = time.perf_counter()
    rec = reconstruct(det, rig, method=Implicit(), progress=progress)
    return trajectory_of(rec, method="implicit trajectory fit", elapsed_s=time.perf_counter() - t0)


def trajectory_of(rec: Reconstruction, *, method: str | None = None, elapsed_s: float = 0.0) -> Reconstruction:
    """A method's reconstruction as the trial's stages keep it: a continuous fit sampled through the
    :func:`dense_sampler` (what its file holds, so a result read back is the same) and without agreeing views
    (its points are samples of a function); triangulations keep theirs; metrics JSON-ready."""
    points, times = np.asarray(rec.points_mm), np.asarray(rec.times_s)
    continuous = rec.trajectory is not None
    return replace(rec, method=method or rec.method, points_mm=points, times_s=times,
                   joint_names=tuple(rec.joint_names), camera_names=tuple(str(n) for n in rec.camera_names),
                   quality=None if continuous else np.asarray(rec.quality),
                   trajectory=dense_sampler(rec.sample, times) if continuous else None,
                   metrics=_plain_metrics(rec.metrics), elapsed_s=elapsed_s)


def gait_of(traj: Reconstruction, *, reprojection_px: np.ndarray | None = None):
    """Gait analysis of a trajectory: (GaitReport or None, the reason there is none ("" when there is)).
    ``reprojection_px``: (T, J) px per point when known (a result file's), else unknown."""
    from gaitcap.reconstruction.gait import TrajectoryQuality, analyze_gait

    quality = None if traj.quality is None else TrajectoryQuality(
        num_views=traj.quality,
        reprojection_px=np.full(traj.quality.shape, np.nan) if reprojection_px is None else reprojection_px)
    try:
        return analyze_gait(traj.points_mm, traj.times_s, list(traj.joint_names), sample=traj.trajectory,
                            quality=quality), ""
    except ValueError as exc:
        return None, str(exc)


# ---------------------------------------------------------------------------------------------- the patient
USABLE_CONFIDENCE = 0.1  # a view of a joint below this confidence is not an observation


class NoUsableObservations(ValueError):
    """The input has nothing to reconstruct (the message says what is missing)."""


def check_usable(det: MultiViewKeypoints, *, min_confidence: float = USABLE_CONFIDENCE) -> None:
    """NoUsableObservations naming what is missing: no camera frame has a joint above ``min_confidence``
    (which cameras), or no joint is seen by two cameras in any frame (which joints each camera sees)."""
    kp = det.one_person
    seen = (np.nan_to_num(kp[..., 2]) > min_confidence) & np.isfinite(kp[..., :2]).all(-1)  # (C, T, J)
    empty = [n for n, s in zip(det.camera_names, seen.any((1, 2)), strict=True) if not s]
    if len(empty) == len(det.camera_names):
        raise NoUsableObservations(f"no usable observation: every confidence of every camera ({', '.join(empty)}) is "
                                   f"at or below {min_confidence} (or its pixels are NaN)")
    if not (seen.sum(0) >= 2).any():
        per_cam = "; ".join(f"{n}: {int(s.any(0).sum())} joints" for n, s in zip(det.camera_names, seen, strict=True))
        raise NoUsableObservations(f"no usable observation: no joint is seen by two cameras in any frame with "
                                   f"confidence > {min_confidence} ({per_cam}; cameras with none: {empty or 'none'})")


def resolve_layout(recording, rig: Rig, *, named: str | None):
    """The recording in its keypoint layout, and the :class:`~gaitcap.reconstruction.layout_guess.LayoutChoice`.

    Every layout with the recording's keypoint count is scored on the patient's triangulated keypoints
    (:mod:`gaitcap.reconstruction.layout_guess`); ``named`` (the input's metadata or ``--skeleton``) wins,
    with a warning when another layout fits clearly better. AmbiguousLayout when none is named and two
    fit alike; the choice and its evidence are logged."""
    from gaitcap.reconstruction.layout_guess import (
        candidate_layouts,
        choose_layout,
        sample_points,
        score_layout,
    )
    from gaitcap.services.processing.people import patient_of

    scores, problems = [], []
    for skel in candidate_layouts(recording.shape[-1]):
        rec = replace(recording, skeleton=skel.name)
        try:
            det, sub = patient_of(rec, rig).aligned_to(rig)
            scores.append(score_layout(sample_points(det, sub), skel))
        except ValueError as exc:  # the people cannot even be associated under this layout
            log.info("layout %s: not scored (%s)", skel.name, exc)
            problems.append(f"{skel.name}: {exc}")
    if not scores:
        raise ValueError(f"keypoint layout: no layout with {recording.shape[-1]} keypoints could be scored "
                         f"({'; '.join(problems)}); check that the calibration matches the images")
    choice = choose_layout(scores, explicit=named)
    log.info("%s", choice.evidence())
    for warning in choice.warnings:
        log.warning("%s", warning)
    return replace(recording, skeleton=choice.skeleton), choice


def patient_input(recording, rig: Rig, *, files=None, choice=None, selector=None) -> tuple[MultiViewKeypoints, Rig, object]:
    """The patient's detections aligned to the rig's cameras, checked usable, and the selection (None with
    one person in view). ``files``: the trial's :class:`~gaitcap.services.processing.artifacts.TrialFiles`
    (then ``people.json`` / ``tracks.npz`` are written when several people are in view); ``selector``: how
    to choose the patient (a track selector; default: the clinician's stored choice, else automatic);
    ``choice``: the clinician's choice when ``files`` is None (reprocessing reads it without writing)."""
    from gaitcap.services.processing.people import patient_detections_of, patient_selection

    if files is not None:
        det, selection = patient_detections_of(recording, rig, files, selector=selector)
    else:
        det, selection = patient_selection(recording, rig, choice, selector=selector)
    det, rig = det.aligned_to(rig)
    check_usable(det)
    return det, rig, selection


def dense_grid(times_s: np.ndarray, *, oversample: int = 4) -> np.ndarray:
    """Times (s) ``oversample`` times finer than the frames, from the first frame to the last."""
    return np.linspace(float(times_s[0]), float(times_s[-1]), oversample * (len(times_s) - 1) + 1)


def dense_sampler(sample: Callable[[np.ndarray], np.ndarray], times_s: np.ndarray, *, oversample: int = 4):
    """Evaluate a continuous trajectory once on the :func:`dense_grid` and return a cubic-spline sampler
    over it (times clipped to the trial): one call to the fitted function instead of one per event
    search, same values to well under a millimetre for a band-limited fit."""
    grid = dense_grid(times_s, oversample=oversample)
    return spline_sampler(grid, np.asarray(sample(grid)))


def spline_sampler(grid_s: np.ndarray, dense_mm: np.ndarray):
    """``sample(times_s (N,)) -> (N, J, 3)`` mm: the cubic spline through ``dense_mm`` (G, J, 3) at
    ``grid_s`` (G,) s, times clipped to the grid. It passes through its samples, so the samples of a
    sampler (a result file's ``dense_points_mm``) rebuild the same sampler."""
    from scipy.interpolate import CubicSpline

    grid_s, dense_mm = np.asarray(grid_s, dtype=np.float64), np.asarray(dense_mm)
    lo, hi = float(grid_s[0]), float(grid_s[-1])
    spline = CubicSpline(grid_s, dense_mm.reshape(len(grid_s), -1), axis=0)

    def sampled(t: np.ndarray) -> np.ndarray:
        t = np.clip(np.asarray(t, dtype=np.float64), lo, hi)
        return spline(t).reshape(*t.shape, *dense_mm.shape[1:])

    return sampled


def _plain_metrics(metrics: dict) -> dict:
    """Scalar metrics only (GC_d, losses): JSON-ready numbers."""
    out = {}
    for key, value in (metrics or {}).items():
        if isinstance(value, dict):
            out.update({f"{key}.{k}": float(v) for k, v in value.items() if np.isscalar(v)})
        elif np.isscalar(value):
            out[key] = float(value) if not isinstance(value, str) else value
    return out


def warm_up(rig: Rig, skeleton, *, frames: tuple[int, ...] = (FRAME_CHUNK,)) -> float:
    """Compile robust triangulation for the chunk shape; returns the time spent (s)."""
    t0 = time.perf_counter()
    c, j = len(rig.cameras), skeleton.num_joints
    rng = np.random.default_rng(0)
    for t in frames:
        pts = rng.uniform(-300, 300, (t * j, 3)) + np.array([0.0, 0.0, 900.0])
        xy = np.stack([cam.project(pts) for cam in rig.cameras]).reshape(c, t, j, 2)
        kp = np.concatenate([xy, np.ones((c, t, j, 1))], axis=-1)
        det = MultiViewKeypoints.of_one_person(kp, rig.names, np.arange(t) / 30.0, skeleton)
        preliminary(det, rig)
    return time.perf_counter() - t0


def ring_rig(num_cameras: int = 10, *, radius_mm: float = 5000.0, height_mm: float = 2000.0) -> Rig:
    """A ring of cameras looking at the origin (only for compiling code of the right shapes)."""
    from gaitcap.reconstruction.camera import Camera, matrix_to_rodrigues

    cams = []
    for i in range(num_cameras):
        a = 2 * np.pi * i / num_cameras
        center = np.array([radius_mm * np.cos(a), radius_mm * np.sin(a), height_mm])
        z = -center / np.linalg.norm(center)
        x = np.cross(z, [0.0, 0.0, 1.0])
        x /= np.linalg.norm(x)
        rot = np.stack([x, np.cross(z, x), z])
        cams.append(Camera(name=f"cam{i}", size_px=(640, 480),
                           matrix_px=np.array([[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]]),
                           dist=np.zeros(5), rvec=matrix_to_rodrigues(rot), tvec_mm=-rot @ center))
    return Rig(cameras=tuple(cams))


def compile_cache_dir(data_dir: Path) -> Path:
    """Where a worker keeps JAX's persistent compilation cache: JAX's own ``JAX_COMPILATION_CACHE_DIR`` where
    the host sets one (the workers of one host, or its rooms, then share what any of them compiled), else
    ``DATA_DIR/.jax-cache``."""
    shared = os.environ.get("JAX_COMPILATION_CACHE_DIR", "")
    return Path(shared) if shared else Path(data_dir) / ".jax-cache"


def enable_compile_cache(path: Path) -> None:
    """JAX's persistent compilation cache, so a restarted worker is warm sooner."""
    import jax

    path.mkdir(parents=True, exist_ok=True)
    jax.config.update("jax_compilation_cache_dir", str(path))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
