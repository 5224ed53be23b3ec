"""Held-out error of a calibration: the board frame sets split in time into k folds; each fold's frame sets
are left out, the calibration fitted on the rest, and judged on the frame sets it did not see. An
in-sample RMS can be made small by a model that follows noise; the error on views a calibration did not
fit cannot.

The judgement on a fold's frame sets is the one a given calibration gets (:func:`evaluate_rig`): its
cameras held fixed (intrinsics and poses), each frame set's board pose fitted to all the cameras that saw
it (the bundle adjustment's robust loss and outlier rounds, nothing else free), then per camera the
reprojection RMS over all its corners (outliers included) and over the inliers, and the board triangulated
from the inlier corners and measured in 3D (:mod:`gaitcap.reconstruction.calibration.board_check`). An
imported calibration (caliscope's, Pose2Sim's, anipose's) is judged the same way on the same frame sets,
so the two compare on the same frames; but it was made from every frame set (these included), which
favours it. Judged on equal terms, the other tool's calibration is fitted on each fold's training frame
sets as ours is (``cross_validate(..., refit=)``; caliscope's through its scripting API:
:func:`gaitcap.acquisition.importers.caliscope.calibrate_with_caliscope`).

Folds are contiguous in time: neighbouring frames of a hand-held board nearly repeat each other, so a
random split would judge a calibration on near-copies of views it fitted. ``guard_frames`` frame sets on
either side of a held-out block are left out of its fit too. Still runs (the board lying on the floor) are
merged into one frame set before the split, so a run is never on both sides.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np
from gaitcap.reconstruction.calibration.board_check import (
    BoardCheck,
    BoardMeasures,
    measure_board,
    size_problem,
    summarize_board,
)
from gaitcap.reconstruction.calibration.bundle import BundleConfig
from gaitcap.reconstruction.calibration.geometry import BoardObservations
from gaitcap.reconstruction.calibration.refit import board_fit
from gaitcap.reconstruction.calibration.still import merge_still_frames
from gaitcap.reconstruction.camera import Rig

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class HoldoutConfig:
    """How the held-out error is measured.

    Attributes:
        folds: k, the number of contiguous blocks in time (each left out once); at least 2.
        guard_frames: frame sets on either side of a held-out block also left out of its fit.
        max_square_pct: the 3D check's tolerance on the square size (and columns vs rows), %.
    """

    folds: int = 5
    guard_frames: int = 1
    max_square_pct: float = 1.0

    def __post_init__(self) -> None:
        if self.folds < 2:
            raise ValueError(f"held-out error: folds must be at least 2, got {self.folds}")


@dataclass(frozen=True)
class CameraHoldout:
    """One camera on the held-out frame sets: views held out and judged (a view no pose of the calibration
    fits is not judged), corners, reprojection RMS over all its corners (outliers included: the headline),
    over the inliers and the median (px), outlier corners, and the 3D square error over the neighbour
    pairs it saw (mm)."""

    name: str
    views_held_out: int
    views_judged: int
    corners: int
    rms_px: float
    rms_inlier_px: float
    median_px: float
    outliers: int
    square_error_rms_mm: float


@dataclass(frozen=True)
class HoldoutEvaluation:
    """One calibration judged on held-out frame sets (``label``: whose); ``folds`` tried, ``fold_errors``:
    why a fold could not be fitted (its frame sets are then judged for no calibration); ``seconds``: the
    fits' and judgements' time."""

    label: str
    folds: int
    fold_errors: tuple[str, ...]
    frame_sets: int
    cameras: tuple[CameraHoldout, ...]
    rms_px: float
    rms_inlier_px: float
    board: BoardCheck
    problems: tuple[str, ...]
    seconds: float

    def camera(self, name: str) -> CameraHoldout:
        return next(c for c in self.cameras if c.name == name)

    def to_dict(self) -> dict:
        out = asdict(self)
        out["board"]["square_residual_pct"] = self.board.square_residual_pct
        return out


def time_folds(obs: BoardObservations, folds: int) -> np.ndarray:
    """(F,) fold index of every frame set (-1: no usable view): those with a view, in time order, cut into
    ``folds`` contiguous blocks of about equal numbers of views (ValueError when there are fewer frame sets
    than folds)."""
    views = obs.views()
    used = np.flatnonzero(views.any(0))
    if len(used) < folds:
        raise ValueError(f"held-out error: {len(used)} frame sets with a board view, fewer than the {folds} folds")
    order = used[np.argsort(obs.times_s[used], kind="stable")]
    weight = np.cumsum(views[:, order].sum(0))
    block = np.minimum((folds * (weight - 1)) // weight[-1], folds - 1)
    out = np.full(obs.shape[1], -1)
    out[order] = block
    return out


def frames_of(obs: BoardObservations, keep: np.ndarray) -> BoardObservations:
    """The observations of the frame sets ``keep`` (F,) bool only."""
    return BoardObservations(obs.camera_names, obs.image_sizes_px, obs.corners_px[:, keep], obs.board,
                             obs.times_s[keep])


def _training(fold_of: np.ndarray, times: np.ndarray, fold: int, guard: int) -> np.ndarray:
    """(F,) bool: the frame sets a fold's calibration is fitted on (not held out, not within ``guard``
    frame sets of the held-out block in time)."""
    used = np.flatnonzero(fold_of >= 0)
    order = used[np.argsort(times[used], kind="stable")]
    pos = np.flatnonzero(fold_of[order] == fold)
    near = np.zeros(len(order), dtype=bool)
    near[max(pos.min() - guard, 0): pos.max() + guard + 1] = True
    train = np.zeros(len(fold_of), dtype=bool)
    train[order[~near]] = True
    return train


@dataclass(frozen=True, eq=False)
class _Judged:
    """One fold's judgement: per corner camera, error norm (px) and inlier flag; the views judged; the 3D
    measures."""

    cam: np.ndarray
    err_px: np.ndarray
    inlier: np.ndarray
    views: np.ndarray
    board: BoardMeasures


def _judge(obs: BoardObservations, rig: Rig, bundle: BundleConfig) -> _Judged:
    missing = [n for n in obs.camera_names if n not in rig.names]
    if missing:
        raise ValueError(f"held-out error: the calibration has no cameras {missing} (it has {list(rig.names)})")
    fit = board_fit(obs, rig, config=bundle)
    prob, res = fit.problem, fit.result
    cams = [rig[n] for n in obs.camera_names]
    extr = np.stack([np.concatenate([c.rotation, c.tvec_mm[:, None]], 1) for c in cams])
    measures = measure_board(fit.ordered_inliers_px(), np.stack([c.matrix_px for c in cams]),
                             np.stack([c.dist for c in cams]), extr, obs.board)
    views = np.array([len(np.unique(prob.frame[prob.cam == c])) for c in range(obs.shape[0])])
    return _Judged(prob.cam, np.linalg.norm(res.residual_px, axis=-1), res.inlier, views, measures)


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x**2))) if x.size else float("nan")


def _summary(label: str, obs: BoardObservations, judged: list[_Judged], held_views: np.ndarray, folds: int,
             errors: tuple[str, ...], frame_sets: int, seconds: float, config: HoldoutConfig) -> HoldoutEvaluation:
    cam = np.concatenate([j.cam for j in judged]) if judged else np.zeros(0, int)
    err = np.concatenate([j.err_px for j in judged]) if judged else np.zeros(0)
    inl = np.concatenate([j.inlier for j in judged]) if judged else np.zeros(0, bool)
    board = summarize_board([j.board for j in judged], obs.board, obs.camera_names)
    cameras = []
    for c, name in enumerate(obs.camera_names):
        mine = cam == c
        cameras.append(CameraHoldout(
            name, int(held_views[c]), int(sum(j.views[c] for j in judged)), int(mine.sum()), _rms(err[mine]),
            _rms(err[mine & inl]), float(np.median(err[mine])) if mine.any() else float("nan"),
            int((mine & ~inl).sum()), board.per_camera_square_error_rms_mm[name]))
    problem = size_problem(board, max_pct=config.max_square_pct, who=label)
    return HoldoutEvaluation(label, folds, errors, frame_sets, tuple(cameras), _rms(err), _rms(err[inl]), board,
                             (problem,) if problem else (), seconds)


@dataclass(frozen=True)
class HoldoutComparison:
    """The held-out error of calibrations fitted here (``own``) and, on the same frame sets, of a given one
    (``reference``, None when none was given: made from every frame set, so in-sample for it when it was
    made from this recording) and of another tool's calibration fitted on each fold's frame sets as ours
    is (``refitted``, None when not asked: held out for it as for ours)."""

    own: HoldoutEvaluation
    reference: HoldoutEvaluation | None
    refitted: HoldoutEvaluation | None = None

    def to_dict(self) -> dict:
        return {"own": self.own.to_dict(), "reference": self.reference.to_dict() if self.reference else None,
                "refitted": self.refitted.to_dict() if self.refitted else None}


def cross_validate(
    obs: BoardObservations, calibrate: Callable[[BoardObservations], Rig], *, reference: Rig | None = None,
    reference_label: str = "the reference calibration", config: HoldoutConfig | None = None,
    bundle: BundleConfig | None = None, progress: Callable[[int, int], None] | None = None,
    refit: Callable[[BoardObservations], Rig] | None = None, refit_label: str = "the other calibration",
) -> HoldoutComparison:
    """k-fold held-out error of ``calibrate`` (board observations -> rig; a ValueError it raises for a fold
    is reported in ``fold_errors``), and of ``reference`` on the same held-out frame sets. ``refit``:
    another calibration procedure (e.g. caliscope's own, :func:`gaitcap.acquisition.importers.caliscope.
    calibrate_with_caliscope`) fitted on each fold's training frame sets exactly as ``calibrate`` is and
    judged on the same held-out ones (``refitted``); a fold either could not fit is judged for none, and
    is named in both evaluations' ``fold_errors`` with whose fit failed."""
    config, bundle = config or HoldoutConfig(), bundle or BundleConfig()
    merged, _ = merge_still_frames(obs)
    fold_of = time_folds(merged, config.folds)
    views = merged.views()
    own, ref, other, errors = [], [], [], []
    held = np.zeros(merged.shape[0], dtype=int)
    t_own = t_ref = t_other = 0.0
    sets = 0
    for k in range(config.folds):
        test = fold_of == k
        train = frames_of(merged, _training(fold_of, merged.times_s, k, config.guard_frames))
        where = f"fold {k + 1} of {config.folds} (frame sets {np.flatnonzero(test).min()}-{np.flatnonzero(test).max()} left out)"
        t0 = time.perf_counter()
        try:
            rig = calibrate(train)
        except ValueError as exc:
            errors.append(f"{where}: {exc}")
            log.warning("held-out error: %s", errors[-1])
            continue
        t1 = time.perf_counter()
        if refit is not None:
            try:
                refitted = refit(train)
            except ValueError as exc:
                errors.append(f"{where}: {refit_label} not fitted: {exc}")
                log.warning("held-out error: %s", errors[-1])
                t_own, t_other = t_own + t1 - t0, t_other + time.perf_counter() - t1
                continue
        t2 = time.perf_counter()
        held_out = frames_of(merged, test)
        own.append(_judge(held_out, rig, bundle))
        t3 = time.perf_counter()
        if refit is not None:
            other.append(_judge(held_out, refitted, bundle))
        t4 = time.perf_counter()
        if reference is not None:
            ref.append(_judge(held_out, reference, bundle))
        t_own, t_other = t_own + (t1 - t0) + (t3 - t2), t_other + (t2 - t1) + (t4 - t3)
        t_ref += time.perf_counter() - t4
        held += views[:, test].sum(1)
        sets += int(test.sum())
        if progress is not None:
            progress(k + 1, config.folds)
    errors = tuple(errors)
    mine = _summary("this calibration", merged, own, held, config.folds, errors, sets, t_own, config)
    theirs = (_summary(reference_label, merged, ref, held, config.folds, errors, sets, t_ref, config)
              if reference is not None else None)
    refitted = (_summary(refit_label, merged, other, held, config.folds, errors, sets, t_other, config)
                if refit is not None else None)
    return HoldoutComparison(mine, theirs, refitted)


def evaluate_rig(obs: BoardObservations, rig: Rig, *, label: str = "the calibration",
                 config: HoldoutConfig | None = None, bundle: BundleConfig | None = None) -> HoldoutEvaluation:
    """A given calibration judged on every frame set of ``obs`` as on held-out ones (no fold, nothing
    fitted but the board poses): its figures on corners it did not see, when it was made elsewhere."""
    config = config or HoldoutConfig()
    t0 = time.perf_counter()
    merged, _ = merge_still_frames(obs)
    judged = _judge(merged, rig, bundle or BundleConfig())
    return _summary(label, merged, [judged], merged.views().sum(1), 1, (), int(merged.views().any(0).sum()),
                    time.perf_counter() - t0, config)
