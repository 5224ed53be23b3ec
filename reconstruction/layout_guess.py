"""Which keypoint layout a recording is in, from the keypoints themselves.

Several layouts share a joint count (OpenPose's BODY_25 and BODY_25B both have 25 keypoints, in another
order), and a file rarely says which it is. Read under the wrong layout, the same detections give limbs
that join unrelated points: their lengths vary and the body is upside down or mirrored. So every
candidate layout is scored on the same triangulated sample of frames (triangulation works joint by
joint, so the 3D points do not depend on the layout; only the names given to them do):

- ``limb_sd_mm``: median over the layout's limbs (shank, thigh, upper arm, forearm, foot) of the SD of
  the limb's length over the frames, mm;
- ``asymmetry_mm``: median over bilateral limbs of |median left length - median right length|, mm;
- ``misplaced``: the fraction of anatomical checks that fail: shoulders above hips above knees above
  ankles (along the body's own shoulder-hip axis), left joints on the left of the hips' left-right axis,
  nose and toes in front (the facing direction from the hips' left-right axis and the body axis).

The score (mm) is ``limb_sd_mm + asymmetry_mm + MISPLACED_MM * misplaced``; lower is better. The best
layout is chosen when it beats the next one clearly (``LayoutRules``); otherwise :class:`AmbiguousLayout`
names both. An explicit layout always wins; a candidate that clearly beats it gives a warning.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.skeletons import SKELETONS, Skeleton, get_skeleton

log = logging.getLogger(__name__)
MISPLACED_MM = 100.0  # score cost (mm) of a layout whose every anatomical check fails


@dataclass(frozen=True)
class LayoutRules:
    """When the best layout is decisive: the next one scores at least ``min_margin_mm`` more and at
    least ``min_ratio`` times as much. ``implausible_mm``: a chosen layout scoring above this gets a
    warning even when no other layout fits better (limbs inconsistent whatever the names)."""

    min_margin_mm: float = 5.0
    min_ratio: float = 1.5
    implausible_mm: float = 120.0

    def __post_init__(self) -> None:
        if self.min_margin_mm < 0 or self.min_ratio < 1 or self.implausible_mm <= 0:
            raise ValueError(f"LayoutRules: need min_margin_mm >= 0, min_ratio >= 1, implausible_mm > 0; got {self}")

    def decisive(self, best: float, other: float) -> bool:
        return other - best >= self.min_margin_mm and other >= self.min_ratio * best


@dataclass(frozen=True)
class LayoutScore:
    """One layout's fit to the triangulated sample (see the module docstring); mm and a fraction."""

    skeleton: str
    limb_sd_mm: float
    asymmetry_mm: float
    misplaced: float
    frames: int

    @property
    def score_mm(self) -> float:
        return self.limb_sd_mm + self.asymmetry_mm + MISPLACED_MM * self.misplaced

    def describe(self) -> str:
        return (f"{self.skeleton}: limb-length SD {self.limb_sd_mm:.0f} mm, left/right {self.asymmetry_mm:.0f} mm, "
                f"{100 * self.misplaced:.0f} % misplaced (score {self.score_mm:.0f} mm)")


@dataclass(frozen=True)
class LayoutChoice:
    """The layout used, every candidate's score (best first), how it was chosen, and warnings."""

    skeleton: str
    scores: tuple[LayoutScore, ...]
    how: str  # "explicit" | "recognised" | "only candidate"
    warnings: tuple[str, ...] = ()

    @property
    def margin_mm(self) -> float:
        """Score of the next best layout minus the chosen one's (inf with one candidate)."""
        chosen = self.score_of(self.skeleton).score_mm
        others = [s.score_mm for s in self.scores if s.skeleton != self.skeleton]
        return min(others) - chosen if others else math.inf

    def score_of(self, name: str) -> LayoutScore:
        return next(s for s in self.scores if s.skeleton == name)

    def evidence(self) -> str:
        """One line, e.g. "layout body25b (recognised): limb-length SD 4 mm, ...; next best body25 ..."."""
        text = f"layout {self.skeleton} ({self.how}): {self.score_of(self.skeleton).describe()}"
        others = [s for s in self.scores if s.skeleton != self.skeleton]
        return text + (f"; next best {others[0].describe()}" if others else "")


class AmbiguousLayout(ValueError):
    """Two layouts fit the keypoints about equally well."""


def candidate_layouts(num_joints: int) -> tuple[Skeleton, ...]:
    """Every registered layout with ``num_joints`` keypoints (ValueError when there is none)."""
    found = tuple(s for s in SKELETONS.values() if s.num_joints == num_joints)
    if not found:
        counts = sorted({s.num_joints for s in SKELETONS.values()})
        raise ValueError(f"skeleton: no known layout has {num_joints} keypoints (known counts {counts}); "
                         "name it with --skeleton")
    return found


def sample_points(det: MultiViewKeypoints, rig: Rig, *, max_frames: int = 90, min_confidence: float = 0.3) -> np.ndarray:
    """Triangulated points (T', J, 3) mm of up to ``max_frames`` frames, chosen evenly among the frames
    where the most joints are seen by two cameras or more (confidence-weighted least-squares ray
    intersection of the views above ``min_confidence``; plain numpy, no compilation)."""
    from gaitcap.reconstruction.association.geometry import pixel_rays, triangulate_rays

    conf = np.where(np.isfinite(det.one_person[..., :2]).all(-1), np.nan_to_num(det.one_person[..., 2]), 0.0)
    conf = np.where(conf > min_confidence, conf, 0.0)  # (C, T, J)
    counts = ((conf > 0).sum(0) >= 2).sum(-1)  # (T,)
    good = np.flatnonzero(counts >= max(1, int(0.5 * counts.max())))
    if counts.max() == 0:
        raise ValueError(f"layout: no frame has a joint seen by two cameras with confidence > {min_confidence}")
    pick = good[np.linspace(0, good.size - 1, min(max_frames, good.size)).round().astype(int)]
    origins, dirs = pixel_rays(rig.subset(det.camera_names), det.one_person[:, pick, :, :2])
    points, _ = triangulate_rays(origins, np.moveaxis(dirs, 0, 1), np.moveaxis(conf[:, pick], 0, 1)[:, None])
    return points[:, 0]


def _lengths(points: np.ndarray, skel: Skeleton, a: str, b: str) -> np.ndarray:
    d = np.linalg.norm(points[:, skel.index(a)] - points[:, skel.index(b)], axis=-1)
    return d[np.isfinite(d)]


def _limb_stats(points: np.ndarray, skel: Skeleton) -> tuple[float, float]:
    sds, sides = [], {}
    for a, b in skel.limbs:
        d = _lengths(points, skel, a, b)
        if d.size >= 3:
            sds.append(float(np.std(d)))
            if a.startswith(("left_", "right_")) and b.startswith(("left_", "right_")):
                sides[(a, b)] = float(np.median(d))
    asym = [abs(v - sides[(a.replace("left_", "right_"), b.replace("left_", "right_"))])
            for (a, b), v in sides.items()
            if a.startswith("left_") and (a.replace("left_", "right_"), b.replace("left_", "right_")) in sides]
    if not sds:
        raise ValueError(f"layout {skel.name}: no limb seen in three frames or more")
    return float(np.median(sds)), float(np.median(asym)) if asym else 0.0


def _mid(points: np.ndarray, skel: Skeleton, name: str) -> np.ndarray | None:
    if not (skel.has(f"left_{name}") and skel.has(f"right_{name}")):
        return None
    return 0.5 * (points[:, skel.index(f"left_{name}")] + points[:, skel.index(f"right_{name}")])


def _misplaced(points: np.ndarray, skel: Skeleton) -> float:
    """Fraction of failed anatomical checks over the frames where they can be made."""
    shoulders, hips = _mid(points, skel, "shoulder"), _mid(points, skel, "hip")
    if shoulders is None or hips is None:
        return 0.0
    axis = shoulders - hips
    up = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    lateral = points[:, skel.index("left_hip")] - points[:, skel.index("right_hip")]
    lateral = lateral - np.sum(lateral * up, -1, keepdims=True) * up
    lateral /= np.linalg.norm(lateral, axis=-1, keepdims=True)
    forward = np.cross(lateral, up)

    def height(p):
        return np.sum((p - hips) * up, -1)

    checks = []
    knees, ankles = _mid(points, skel, "knee"), _mid(points, skel, "ankle")
    if knees is not None:
        checks.append(height(knees) < 0)
        if ankles is not None:
            checks.append(height(ankles) < height(knees))
    for part in ("shoulder", "knee", "ankle", "eye", "ear"):
        if skel.has(f"left_{part}") and skel.has(f"right_{part}"):
            left_right = points[:, skel.index(f"left_{part}")] - points[:, skel.index(f"right_{part}")]
            checks.append(np.sum(left_right * lateral, -1) > 0)
    if skel.has("nose"):
        checks.append(np.sum((points[:, skel.index("nose")] - shoulders) * forward, -1) > 0)
        checks.append(height(points[:, skel.index("nose")]) > height(shoulders))
    for side in ("left", "right"):
        if skel.has(f"{side}_heel") and "left_big_toe" in skel.gait_map:
            toe = points[:, skel.gait_map[f"{side}_big_toe"]]
            checks.append(np.sum((toe - points[:, skel.index(f"{side}_heel")]) * forward, -1) > 0)
    valid = np.isfinite(np.sum(axis, -1)) & np.isfinite(np.sum(lateral, -1))
    results = [(c, valid & np.isfinite(c.astype(float))) for c in checks]
    done = sum(int(ok.sum()) for _, ok in results)
    return 1.0 - sum(int((c & ok).sum()) for c, ok in results) / done if done else 0.0


def score_layout(points_mm: np.ndarray, skeleton: Skeleton | str) -> LayoutScore:
    """How well ``points_mm`` (T, J, 3) mm fit ``skeleton`` (see the module docstring)."""
    skel = get_skeleton(skeleton) if isinstance(skeleton, str) else skeleton
    pts = np.asarray(points_mm, dtype=np.float64)
    if pts.ndim != 3 or pts.shape[1:] != (skel.num_joints, 3):
        raise ValueError(f"points_mm: expected (T, {skel.num_joints}, 3) for {skel.name}, got {pts.shape}")
    sd, asym = _limb_stats(pts, skel)
    with np.errstate(invalid="ignore", divide="ignore"):
        misplaced = _misplaced(pts, skel)
    frames = int(np.isfinite(pts).all(-1).any(-1).sum())
    return LayoutScore(skel.name, sd, asym, misplaced, frames)


def choose_layout(scores: list[LayoutScore] | tuple[LayoutScore, ...], *, explicit: str | None = None,
                  rules: LayoutRules = LayoutRules()) -> LayoutChoice:
    """The layout to use among scored candidates (see the module docstring).

    Raises :class:`AmbiguousLayout` naming the two closest layouts and the ``--skeleton`` flag when no
    explicit layout is given and the best is not decisive.
    """
    ranked = tuple(sorted(scores, key=lambda s: s.score_mm))
    if not ranked:
        raise ValueError("layout: no candidate scored")
    best = ranked[0]
    if explicit is not None:
        name = get_skeleton(explicit).name
        if name not in {s.skeleton for s in ranked}:
            raise ValueError(f"--skeleton {name}: the keypoints have {len(ranked)} candidate layouts "
                             f"{[s.skeleton for s in ranked]}, not this one")
        mine = next(s for s in ranked if s.skeleton == name)
        warnings = []
        if best.skeleton != name and rules.decisive(best.score_mm, mine.score_mm):
            warnings.append(f"--skeleton {name} looks inconsistent with these keypoints ({mine.describe()}); "
                            f"{best.describe()} fits clearly better")
        elif mine.score_mm > rules.implausible_mm:
            warnings.append(f"layout {name}: limbs are inconsistent ({mine.describe()})")
        return LayoutChoice(name, ranked, "explicit", tuple(warnings))
    if len(ranked) > 1 and not rules.decisive(best.score_mm, ranked[1].score_mm):
        raise AmbiguousLayout(
            f"keypoint layout: {best.skeleton} and {ranked[1].skeleton} fit these keypoints about equally well "
            f"({best.describe()}; {ranked[1].describe()}); say which with --skeleton {best.skeleton} or "
            f"--skeleton {ranked[1].skeleton}")
    warnings = ()
    if best.score_mm > rules.implausible_mm:
        warnings = (f"layout {best.skeleton}: limbs are inconsistent ({best.describe()}); check the calibration "
                    "and the keypoint layout",)
    return LayoutChoice(best.skeleton, ranked, "recognised" if len(ranked) > 1 else "only candidate", warnings)
