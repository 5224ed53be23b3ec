"""Intrinsics the footage supports, chosen by held-out error: each candidate (a lens model and a principal
point held at the image centre or free) is applied to every camera and cross-validated in time
(:mod:`gaitcap.reconstruction.calibration.holdout`); each camera then takes the simplest candidate whose
held-out reprojection RMS is within ``tolerance`` of its best. Views bunched near the image centre cannot
tell a shifted principal point from a turned camera, and a sparse clip does not pin down five distortion
terms: a model that follows noise fits its own views better and the views it did not see worse, which
the held-out error shows. The figures that made each choice are kept (:class:`IntrinsicsChoice`).

Each camera's choice is made on its own figures, but the cameras are fitted together: the choices are
cross-validated together, and where the rig's held-out RMS is then above that of the best single
candidate applied to every camera, that candidate is taken for every camera (said in each reason).
Identical cameras (the same image size, focal lengths within a few per cent) may then share a focal length
prior (``CalibrationConfig.share_focal``), kept when it lowers the rig's held-out error.

Cost: one k-fold cross-validation per candidate (candidates x k calibrations), one more for the choices
together, one for the prior.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
from gaitcap.reconstruction.calibration.geometry import BoardObservations
from gaitcap.reconstruction.calibration.holdout import HoldoutConfig, HoldoutEvaluation, cross_validate
from gaitcap.reconstruction.calibration.intrinsics import DistortionModel, PrincipalPoint
from gaitcap.reconstruction.calibration.pipeline import CalibrationConfig, calibrate_from_observations

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Candidate:
    """A lens model and where the principal point comes from, for every camera alike."""

    distortion: DistortionModel
    principal_point: PrincipalPoint

    @property
    def label(self) -> str:
        return f"{self.distortion.value}, principal point {self.principal_point.value}"

    @property
    def unknowns(self) -> int:
        """Intrinsic unknowns per camera (focal lengths, principal point, distortion terms)."""
        return 2 + 2 * (self.principal_point is not PrincipalPoint.HELD) + len(self.distortion.free)


CANDIDATES = tuple(Candidate(d, p) for d in DistortionModel for p in (PrincipalPoint.HELD, PrincipalPoint.FREE))


@dataclass(frozen=True)
class IntrinsicsChoice:
    """The candidates (labels), each camera's held-out reprojection RMS (px, over all its held-out corners)
    under each (NaN: that candidate could not be fitted in every fold, ``failures`` says why), the label
    chosen per camera with the reason in plain words, the folds and the time the choice took (s);
    shared_focal: whether identical cameras share a focal length prior, and the figures (empty: not tried);
    rig_rms_px: each candidate's held-out RMS over the whole rig (px, NaN: not fitted in every fold);
    combined_rms_px: the rig's held-out RMS with the intrinsics finally chosen (px); fallback: why the
    best single candidate was taken for every camera instead of each camera's own choice (empty: not)."""

    candidates: tuple[str, ...]
    held_out_rms_px: dict[str, tuple[float, ...]]
    chosen: dict[str, str]
    reasons: dict[str, str]
    failures: dict[str, tuple[str, ...]]
    folds: int
    seconds: float
    shared_focal: str = ""
    rig_rms_px: tuple[float, ...] = ()
    combined_rms_px: float = float("nan")
    fallback: str = ""

    def to_dict(self) -> dict:
        return {"candidates": list(self.candidates), "held_out_rms_px": {k: list(v) for k, v in self.held_out_rms_px.items()},
                "chosen": self.chosen, "reasons": self.reasons, "failures": {k: list(v) for k, v in self.failures.items()},
                "folds": self.folds, "seconds": self.seconds, "shared_focal": self.shared_focal,
                "rig_rms_px": list(self.rig_rms_px), "combined_rms_px": self.combined_rms_px, "fallback": self.fallback}


def _pick(rms: np.ndarray, candidates: Sequence[Candidate], tolerance: float) -> int:
    """The simplest candidate (fewest unknowns, then listed first) within ``tolerance`` of the best RMS."""
    best = np.nanmin(rms)
    ok = [i for i in range(len(candidates)) if np.isfinite(rms[i]) and rms[i] <= best * (1 + tolerance)]
    return min(ok, key=lambda i: (candidates[i].unknowns, i))


def _reason(rms: np.ndarray, candidates: Sequence[Candidate], pick: int, folds: int) -> str:
    others = ", ".join(f"{c.label} {r:.3f}" for c, r in zip(candidates, rms, strict=True) if np.isfinite(r)
                       and c is not candidates[pick])
    return (f"intrinsics {candidates[pick].label} chosen by held-out error ({folds} folds in time): "
            f"{rms[pick]:.3f} px; {others} px")


def choose_intrinsics(
    obs: BoardObservations, base: CalibrationConfig | None = None, *, candidates: Sequence[Candidate] = CANDIDATES,
    holdout: HoldoutConfig | None = None, tolerance: float = 0.01, share_focal: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> tuple[CalibrationConfig, IntrinsicsChoice]:
    """Each camera's intrinsics candidate by held-out error; returns ``base`` with ``camera_intrinsics``
    set to the choices (each with its reason) and the figures. The choices are cross-validated together
    (one more cross-validation where they differ) and replaced by the best single candidate for every
    camera where that holds out better over the rig. With ``share_focal`` the result is then
    cross-validated with a focal length prior shared by identical cameras (``CalibrationConfig.share_focal``;
    one more), kept where it lowers the rig's held-out RMS. ValueError when no candidate could be fitted in every fold (naming why)."""
    base, holdout = base or CalibrationConfig(), holdout or HoldoutConfig()
    if base.known_intrinsics is not None:
        raise ValueError("intrinsics choice: the intrinsics are given (known_intrinsics); nothing to choose")
    t0 = time.perf_counter()
    names = obs.camera_names
    table = np.full((len(names), len(candidates)), np.nan)
    rig_rms = np.full(len(candidates), np.nan)
    failures: dict[str, tuple[str, ...]] = {}
    for i, cand in enumerate(candidates):
        intr = replace(base.intrinsics, distortion=cand.distortion, principal_point=cand.principal_point)
        config = replace(base, intrinsics=intr, camera_intrinsics=None)
        result = _held_out(obs, config, holdout)
        if result.fold_errors:
            failures[cand.label] = result.fold_errors
        else:
            table[:, i] = [result.camera(n).rms_px for n in names]
            rig_rms[i] = result.rms_px
        log.info("intrinsics candidate %s: held-out RMS %s", cand.label, np.round(table[:, i], 3))
        if progress is not None:
            progress(i + 1, len(candidates))
    if np.isnan(table).all():
        raise ValueError("intrinsics choice: no candidate could be calibrated in every fold: "
                         + "; ".join(f"{k}: {v[0]}" for k, v in failures.items()))
    picks = [_pick(table[c], candidates, tolerance) for c in range(len(names))]
    if len(set(picks)) == 1:
        combined_rms = float(rig_rms[picks[0]])
    else:
        combined = _held_out(obs, _per_camera(base, names, candidates, picks, table, holdout.folds), holdout)
        combined_rms = float("nan") if combined.fold_errors else combined.rms_px
    picks, combined_rms, fallback = best_single_fallback(picks, rig_rms, combined_rms, candidates)
    chosen_config = _per_camera(base, names, candidates, picks, table, holdout.folds, fallback)
    shared = _shared_focal(obs, chosen_config, holdout, combined_rms) if share_focal else None
    if shared is not None and shared[0]:
        chosen_config = replace(chosen_config, share_focal=True)
    choice = IntrinsicsChoice(
        tuple(c.label for c in candidates), {n: tuple(table[c]) for c, n in enumerate(names)},
        {n: candidates[p].label for n, p in zip(names, picks, strict=True)},
        {n: chosen_config.intrinsics_of(n).chosen_because for n in names}, failures, holdout.folds,
        time.perf_counter() - t0, shared[1] if shared is not None else "", tuple(float(r) for r in rig_rms),
        combined_rms, fallback)
    return chosen_config, choice


def best_single_fallback(picks: list[int], rig_rms: np.ndarray, combined_rms: float,
                         candidates: Sequence[Candidate]) -> tuple[list[int], float, str]:
    """Each camera's candidate ``picks`` as they are, or the best single candidate for every camera where
    it held out better over the rig (``rig_rms`` (K,) px per candidate, NaN: not fitted in every fold)
    than the picks together (``combined_rms`` px, NaN: they failed in a fold): (picks, the rig's held-out
    RMS px with them, why the fallback was taken or empty)."""
    best = int(np.nanargmin(rig_rms))
    if len(set(picks)) == 1 or combined_rms <= rig_rms[best]:
        return list(picks), float(combined_rms), ""
    why = (f"each camera's own choice together held out {combined_rms:.3f} px over the rig, the best single "
           f"candidate ({candidates[best].label}) {rig_rms[best]:.3f} px: it is taken for every camera")
    log.info("intrinsics choice: %s", why)
    return [best] * len(picks), float(rig_rms[best]), why


def _held_out(obs: BoardObservations, config: CalibrationConfig, holdout: HoldoutConfig):
    """The held-out evaluation of calibrations made with ``config``."""
    return cross_validate(obs, lambda o: calibrate_from_observations(o, config=config).rig, config=holdout,
                          bundle=config.bundle).own


def _per_camera(base: CalibrationConfig, names, candidates: Sequence[Candidate], picks: list[int],
                table: np.ndarray, folds: int, fallback: str = "") -> CalibrationConfig:
    """``base`` with each camera's (``names``) candidate ``picks`` (its reason from its row of ``table``)."""
    per_camera = {}
    for c, (name, pick) in enumerate(zip(names, picks, strict=True)):
        reason = _reason(table[c], candidates, pick, folds) + (f" ({fallback})" if fallback else "")
        per_camera[name] = replace(base.intrinsics, distortion=candidates[pick].distortion,
                                                 principal_point=candidates[pick].principal_point,
                                                 chosen_because=reason)
    return replace(base, camera_intrinsics=per_camera, share_focal=False)


def _shared_focal(obs: BoardObservations, config: CalibrationConfig, holdout: HoldoutConfig,
                  without_rms: float) -> tuple[bool, str]:
    """Whether identical cameras should share a focal length prior: the chosen intrinsics (held out
    ``without_rms`` px without it) cross-validated with it, judged on the rig's held-out RMS; (share,
    the figures in plain words)."""
    own = _held_out(obs, replace(config, share_focal=True), holdout)
    rms = [without_rms, float("nan") if own.fold_errors else own.rms_px]
    share = bool(np.isfinite(rms[1]) and (not np.isfinite(rms[0]) or rms[1] < rms[0]))
    return share, (f"focal length prior shared by identical cameras {'chosen' if share else 'not chosen'} by "
                   f"held-out error: rig RMS {rms[1]:.3f} px with it, {rms[0]:.3f} px without")


# The fit itself chosen by held-out error: the bundle adjustment's loss and, where intrinsics are given
# (e.g. from a separate intrinsics session), whether to hold them or estimate the cameras' own from the
# board clip. Every candidate is judged by the same yardstick (the default BundleConfig's board-pose fit
# on the held-out frame sets), whatever loss it was fitted with.
LOSSES = (("soft-L1 (1 px)", None), ("least squares", "linear"))


@dataclass(frozen=True)
class FitChoice:
    """The fit candidates (labels), each one's held-out reprojection RMS over the rig and per camera (px,
    NaN: not fitted in every fold, ``failures`` says why), the label chosen with the reason, the folds and
    the time the choice took (s)."""

    candidates: tuple[str, ...]
    rig_rms_px: tuple[float, ...]
    camera_rms_px: dict[str, tuple[float, ...]]
    failures: dict[str, tuple[str, ...]]
    chosen: str
    reason: str
    folds: int
    seconds: float

    def to_dict(self) -> dict:
        return {"candidates": list(self.candidates), "rig_rms_px": list(self.rig_rms_px),
                "camera_rms_px": {k: list(v) for k, v in self.camera_rms_px.items()},
                "failures": {k: list(v) for k, v in self.failures.items()}, "chosen": self.chosen,
                "reason": self.reason, "folds": self.folds, "seconds": self.seconds}


def fit_candidates(base: CalibrationConfig) -> dict[str, CalibrationConfig]:
    """The fits :func:`choose_fit` tries, ``base`` first: each loss of :data:`LOSSES`, and where ``base``
    gives intrinsics, each with them held and with the cameras' own from the clip (``base.intrinsics``'
    rules)."""
    sources = [("", base)]
    if base.known_intrinsics is not None:
        sources = [("given intrinsics held, ", base), ("intrinsics from the clip, ", replace(base, known_intrinsics=None))]
    out = {}
    for prefix, config in sources:
        for label, loss in LOSSES:
            bundle = config.bundle if loss is None else replace(config.bundle, loss=loss)
            out[prefix + label] = replace(config, bundle=bundle)
    return out


def choose_fit(obs: BoardObservations, base: CalibrationConfig | None = None, *,
               holdout: HoldoutConfig | None = None, tolerance: float = 0.01,
               progress: Callable[[int, int], None] | None = None,
               evaluated: Mapping[str, HoldoutEvaluation] | None = None) -> tuple[CalibrationConfig, FitChoice]:
    """The fit (:func:`fit_candidates`) whose calibrations hold out best over the rig: the lowest held-out
    reprojection RMS among the candidates fitted in every fold, or the first listed within ``tolerance``
    (relative) of it (``base`` comes first). Returns that candidate's config and the figures; ValueError
    when no candidate could be fitted in every fold. The figure of the candidate chosen is the best of a
    few on the same folds: slightly optimistic for it. ``evaluated``: {candidate label: its held-out
    evaluation with the same ``holdout``, measured already} (not cross-validated again)."""
    base, holdout = base or CalibrationConfig(), holdout or HoldoutConfig()
    t0 = time.perf_counter()
    configs = fit_candidates(base)
    labels = tuple(configs)
    rig = np.full(len(labels), np.nan)
    per_cam = np.full((len(obs.camera_names), len(labels)), np.nan)
    failures: dict[str, tuple[str, ...]] = {}
    for i, (label, config) in enumerate(configs.items()):
        result = (evaluated or {}).get(label) or cross_validate(
            obs, lambda o, config=config: calibrate_from_observations(o, config=config).rig, config=holdout).own
        if result.fold_errors:
            failures[label] = result.fold_errors
        else:
            rig[i] = result.rms_px
            per_cam[:, i] = [result.camera(n).rms_px for n in obs.camera_names]
        log.info("fit candidate %s: held-out RMS %.3f px", label, rig[i])
        if progress is not None:
            progress(i + 1, len(labels))
    if np.isnan(rig).all():
        raise ValueError("fit choice: no candidate could be calibrated in every fold: "
                         + "; ".join(f"{k}: {v[0]}" for k, v in failures.items()))
    best = float(np.nanmin(rig))
    pick = next(i for i in range(len(labels)) if np.isfinite(rig[i]) and rig[i] <= best * (1 + tolerance))
    others = ", ".join(f"{lab} {r:.3f}" if np.isfinite(r) else f"{lab} not fitted in every fold"
                       for lab, r in zip(labels, rig, strict=True) if lab != labels[pick])
    reason = (f"fit {labels[pick]} chosen by held-out error ({holdout.folds} folds in time): rig RMS "
              f"{rig[pick]:.3f} px; {others}")
    log.info("%s", reason)
    choice = FitChoice(labels, tuple(float(r) for r in rig),
                       {n: tuple(float(v) for v in per_cam[c]) for c, n in enumerate(obs.camera_names)}, failures,
                       labels[pick], reason, holdout.folds, time.perf_counter() - t0)
    return configs[labels[pick]], choice
