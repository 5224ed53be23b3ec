"""The rig checked from the walking patient: has a camera moved since it was calibrated?

Each camera is judged against points triangulated from the OTHER cameras (leave one out), so a camera
cannot hide its own error by pulling the points towards itself. Its residuals against those points are
split into two parts by refitting the camera's pose (rotation about its centre and a shift of the centre)
to them with a robust loss:

- the **systematic field**: how far (px) the refitted pose moves the points in the image compared with the
  calibrated pose. A camera rotated or moved after calibration shifts every point coherently, by several px
  for a fraction of a degree; detector noise averages out over thousands of points and leaves it near 0.
- the **noise**: what is left after the refit (the detector's scatter, the other cameras' error).

How much of the systematic field the noise alone could produce is measured, not assumed: the frames are
split into blocks (contiguous in time, since detector errors are correlated from frame to frame) and the
pose is refitted without each block in turn (a delete-one-block jackknife); the spread of those fields
gives the field's standard error.

How finely the trial determines the pose is measured too: the rotation (deg, about the camera's x, y and
optical axis) and shift (mm) that a systematic field of 1 px could produce at the trial's points (from the
refit's information matrix, so a turn that a shift of the centre can mimic, or a turn about the optical
axis of a person seen near the image centre, counts as poorly determined), times twice the **floor**: the
field the detector's own bias and noise leave the cameras that did not move (their median; twice, as one
camera's own bias may exceed the median), or the camera's own field's standard error where larger.
Each camera's estimate comes with those bounds (``rotation_bound_deg``, ``shift_bound_mm``), so a person
standing in one place, who cannot tell a turn from a shift, gives a rotation that says how little it is
worth. A camera is flagged as moved when its field exceeds ``min_field_px``,
``significance`` standard errors and ``rig_ratio`` times the other cameras' median field (a real detector
leaves every camera a field of its own; a moved camera stands out), and its estimated rotation (deg) or
shift (mm) reaches the configured size. Cameras are judged worst first: once a camera is flagged it is left
out of the other cameras' triangulations, so a moved camera does not make its neighbours look moved.

Units: points mm, image points px, rotations deg. Pure computation (numpy, scipy); no I/O.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import asdict, dataclass, replace

import numpy as np
from gaitcap.reconstruction.calibration.geometry import rodrigues_batch, rotation_angle_deg, rvec_of
from gaitcap.reconstruction.camera import Camera, Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.triangulation import robust_triangulate

log = logging.getLogger(__name__)

RAYLEIGH_MEDIAN = float(np.sqrt(2 * np.log(2)))  # median of |e| / sigma for 2D Gaussian noise
BOUND_FACTOR = 2.0  # the bounds are this many floors: the floor is a median, and one camera's bias may exceed it


@dataclass(frozen=True)
class RigCheckConfig:
    """Rig-check settings.

    Attributes:
        min_confidence: keypoints at or below this confidence are not used.
        max_frames: frames used at most (evenly spaced), for speed.
        min_points: a camera with fewer usable keypoints is not judged (``judged`` False).
        blocks: contiguous frame blocks of the jackknife for the field's standard error.
        min_field_px: a field smaller than this (median over the points, px) is never a moved camera.
        significance: the field must exceed this many of its standard errors.
        rig_ratio: and this many times the median field of the other cameras, judged without it: where
            detector biases leave every camera a field of its own (real detectors, a person who barely
            moves), one camera must stand out from the rest.
        rejudge_views: once a camera is flagged, the others are judged again without it only where each
            still has this many other cameras to triangulate from (otherwise their first judgement, with
            the flagged camera, stands, unflagged): from two views a point has no redundancy, so either
            camera's detector bias shows as a field of the one judged, and a 4-camera rig would see a
            second camera "move" with the first.
        min_rotation_deg / min_shift_mm: a flagged camera's estimate must reach one of these.
        robust_scale_px: scale of the soft-L1 loss of the pose refit, px.
        triangulation_sigma_mm: the robust triangulation's sigma (mm) for the leave-one-out points.
    """

    min_confidence: float = 0.5
    max_frames: int = 300
    min_points: int = 200
    blocks: int = 8
    min_field_px: float = 2.0
    significance: float = 5.0
    rig_ratio: float = 2.5
    min_rotation_deg: float = 0.3
    min_shift_mm: float = 10.0
    rejudge_views: int = 3
    robust_scale_px: float = 3.0
    triangulation_sigma_mm: float = 150.0

    def __post_init__(self) -> None:
        if self.blocks < 2:
            raise ValueError(f"rig check: blocks must be >= 2, got {self.blocks}")
        if not 0.0 <= self.min_confidence < 1.0:
            raise ValueError(f"rig check: min_confidence must lie in [0, 1), got {self.min_confidence}")


# CameraCheck.baseline: how a baseline trial was used for the camera
COMPARED = "compared"  # judged by the change since the baseline trial
NOT_JUDGED_THERE = "not judged there"  # the baseline trial saw too few of its keypoints: judged without it
NO_FIELD_THERE = "no field there"  # the baseline trial showed no field of its own: judged as it is


def _has_field(ref: CameraCheck, config: RigCheckConfig) -> bool:
    """Whether the baseline trial shows the camera a field of its own (the detector's bias with the
    calibration as is): one the flagging rules would call significant (``min_field_px`` and
    ``significance`` standard errors). Where it shows none, subtracting its pose offset would only add
    its noise, so the camera is judged as it is."""
    return ref.field_px >= config.min_field_px and ref.field_px >= config.significance * ref.field_se_px


@dataclass(frozen=True)
class CameraCheck:
    """One camera's check.

    Attributes:
        name: the camera.
        judged: False when it had too few usable keypoints (``points`` < ``min_points``) to judge.
        points: keypoints used (confident, with a leave-one-out point).
        residual_px: median reprojection error against the leave-one-out points, px (calibrated pose).
        residual_all_px: median error against the points triangulated from all cameras (the trial's own
            reprojection figure), px.
        refit_residual_px: median error after refitting the pose, px (the detector's and the other cameras'
            share).
        expected_px: the calibration's own reprojection figure for this camera, px (None: not known).
        field_px: median image displacement (px) of the refitted pose from the calibrated one.
        field_se_px: standard error of ``field_px`` from the frame blocks, px.
        rotation_deg: estimated rotation of the camera since calibration, deg.
        shift_mm: estimated shift of its centre, mm.
        moved: flagged as moved.
        turn_deg: the estimated rotation as a rotation vector (3,) deg in the camera's frame (the actual
            world -> camera rotation is ``rodrigues(turn) @ R_calibrated``).
        shift_vector_mm: the estimated shift of the centre (3,) mm in the world frame.
        baseline: how it was judged: ``none`` (no baseline trial given), ``compared`` (the change since the
            baseline trial), ``not judged there`` (the baseline trial saw too few of its keypoints: judged
            without it, and said so) or ``no field there`` (the baseline trial showed the camera no field
            of its own, so the change since it would only add the baseline's noise: judged as it is).
        resolution_deg_per_px: the rotation (deg) about the camera's x (tilt), y (pan) and z (optical) axis
            that a systematic field of 1 px could produce at this trial's points (with a baseline, the larger
            of the trial's and the baseline's) (3,).
        resolution_mm_per_px: the shift of the centre (mm, worst direction) a field of 1 px could produce.
        floor_px: the field (px) the detector's bias leaves the cameras that did not move, or this camera's
            ``field_se_px`` where larger (see the module).
    """

    name: str
    judged: bool
    points: int
    residual_px: float
    residual_all_px: float
    refit_residual_px: float
    expected_px: float | None
    field_px: float
    field_se_px: float
    rotation_deg: float
    shift_mm: float
    moved: bool
    turn_deg: tuple[float, float, float] = (float("nan"),) * 3
    shift_vector_mm: tuple[float, float, float] = (float("nan"),) * 3
    baseline: str = "none"
    resolution_deg_per_px: tuple[float, float, float] = (float("nan"),) * 3
    resolution_mm_per_px: float = float("nan")
    floor_px: float = float("nan")

    @property
    def rotation_bound_deg(self) -> tuple[float, float, float]:
        """How far (deg) the estimated rotation may be off about the camera's x, y and optical axis: the
        rotation a field of twice the floor could produce (3,); NaN where not judged."""
        return tuple(float(BOUND_FACTOR * r * self.floor_px) for r in self.resolution_deg_per_px)

    @property
    def shift_bound_mm(self) -> float:
        """How far (mm) the estimated shift may be off (worst direction); NaN where not judged."""
        return float(BOUND_FACTOR * self.resolution_mm_per_px * self.floor_px)

    def to_dict(self) -> dict:
        return asdict(self) | {"rotation_bound_deg": self.rotation_bound_deg, "shift_bound_mm": self.shift_bound_mm}


@dataclass(frozen=True)
class RigCheck:
    """The rig check of one trial: every camera's check and the warnings naming a moved camera."""

    cameras: tuple[CameraCheck, ...]
    warnings: tuple[str, ...]

    @property
    def moved(self) -> tuple[str, ...]:
        """Names of the cameras flagged as moved."""
        return tuple(c.name for c in self.cameras if c.moved)

    @property
    def flagged(self) -> bool:
        return bool(self.moved)

    def camera(self, name: str) -> CameraCheck:
        for cam in self.cameras:
            if cam.name == name:
                return cam
        raise KeyError(f"rig check: camera {name!r} was not checked (checked: {[c.name for c in self.cameras]})")

    def to_dict(self) -> dict:
        return {"flagged": self.flagged, "moved": list(self.moved), "warnings": list(self.warnings),
                "cameras": {c.name: c.to_dict() for c in self.cameras}}


@dataclass(frozen=True, eq=False)
class PoseFit:
    """A camera pose refitted to fixed points: rotation ``turn`` (3, 3) applied after the calibrated one
    (world -> camera: R = turn @ R0), centre moved by ``shift_mm`` (3,). ``information`` (6, 6): the
    refit's weighted mean J^T J at the solution (px^2 per rad^2 of the rotation vector, per mm^2 of the
    shift); None for a pose that was not fitted."""

    turn: np.ndarray
    shift_mm: np.ndarray
    information: np.ndarray | None = None

    def resolution(self) -> tuple[np.ndarray, float]:
        """The rotation (deg, about the camera's x, y, z axes) (3,) and the shift (mm, worst direction) a
        systematic field of 1 px rms could produce: the square roots of the inverse information's diagonal
        (rotation; the shift's uncertainty traded with it) and of its shift block's largest eigenvalue."""
        cov = np.linalg.pinv(self.information)
        rot = np.degrees(np.sqrt(np.clip(np.diag(cov)[:3], 0.0, None)))
        return rot, float(np.sqrt(max(np.linalg.eigvalsh(cov[3:, 3:]).max(), 0.0)))

    def apply(self, cam: Camera) -> Camera:
        rot = self.turn @ cam.rotation
        centre = cam.center_mm + self.shift_mm
        return cam.replace(rvec=rvec_of(rot), tvec_mm=-rot @ centre)

    @property
    def rotation_deg(self) -> float:
        return float(rotation_angle_deg(self.turn, np.eye(3)))


def _project_moved(cam: Camera, params: np.ndarray, points_mm: np.ndarray) -> np.ndarray:
    """Pixels (N, 2) of points (N, 3) mm seen by ``cam`` turned by rvec params[:3] (rad) about its centre
    and its centre moved by params[3:] (mm)."""
    rot = rodrigues_batch(params[:3]) @ cam.rotation
    pc = (points_mm - (cam.center_mm + params[3:])) @ rot.T
    xy = pc[:, :2] / pc[:, 2:3]
    return cam.distort_normalized(xy) @ cam.matrix_px[:2, :2].T + cam.matrix_px[:2, 2]


def refit_pose(cam: Camera, points_mm: np.ndarray, uv_px: np.ndarray, *, scale_px: float,
               max_iterations: int = 30) -> PoseFit:
    """Robust refit of one camera's pose to fixed points (N, 3) mm and their observed pixels (N, 2) px,
    starting at the calibrated pose: Gauss-Newton on the six unknowns (rotation vector rad, centre shift
    mm) with soft-L1 weights (scale ``scale_px``) by iteratively reweighted least squares."""
    params = np.zeros(6)
    steps = np.r_[np.full(3, 1e-6), np.full(3, 1e-3)]  # finite-difference steps: rad, mm
    for _ in range(max_iterations):
        err = _project_moved(cam, params, points_mm) - uv_px
        weight = 1.0 / np.sqrt(1.0 + np.sum(err**2, -1) / scale_px**2)
        jac = np.stack([((_project_moved(cam, params + np.eye(6)[k] * steps[k], points_mm) - uv_px) - err).ravel()
                        / steps[k] for k in range(6)], -1)  # (2N, 6)
        w2 = np.repeat(weight, 2)
        hess = jac.T @ (jac * w2[:, None])
        delta = np.linalg.solve(hess + 1e-9 * np.diag(np.diag(hess)) + 1e-12 * np.eye(6), -jac.T @ (w2 * err.ravel()))
        params = params + delta
        if np.abs(delta[:3]).max() < 1e-8 and np.abs(delta[3:]).max() < 1e-4:
            break
    return PoseFit(rodrigues_batch(params[:3]), params[3:].copy(), hess / max(float(w2.sum()) / 2, 1e-12))


def _field_px(cam: Camera, fit: PoseFit, points_mm: np.ndarray, reference: PoseFit) -> float:
    """Median image displacement (px) of ``points_mm`` between the refitted pose and the reference pose
    (the calibrated one turned and shifted as on the reference trial; the calibrated one without)."""
    moved = _project_moved(cam, np.r_[rvec_of(fit.turn), fit.shift_mm], points_mm)
    ref = _project_moved(cam, np.r_[rvec_of(reference.turn), reference.shift_mm], points_mm)
    return float(np.median(np.linalg.norm(moved - ref, axis=-1)))


def checked_frames(num_frames: int, max_frames: int = RigCheckConfig.max_frames) -> np.ndarray:
    """The frame indices the check uses: at most ``max_frames``, evenly spaced."""
    step = max(1, int(np.ceil(num_frames / max_frames)))
    return np.arange(0, num_frames, step)


def _without(det: MultiViewKeypoints, cameras: list[int]) -> MultiViewKeypoints:
    kp = det.one_person.copy()
    kp[cameras, ..., 2] = 0.0
    return MultiViewKeypoints.of_one_person(kp, det.camera_names, det.times_s, det.skeleton)


def _loo_points(det: MultiViewKeypoints, rig: Rig, left_out: list[int], config: RigCheckConfig) -> np.ndarray:
    """Points (T, J, 3) mm triangulated without the cameras ``left_out`` (NaN where < 2 views)."""
    sub = _without(det, left_out)
    return robust_triangulate(sub, rig, gamma=config.min_confidence, sigma_mm=config.triangulation_sigma_mm).points_mm


def _median_error(cam: Camera, points_mm: np.ndarray, uv_px: np.ndarray) -> float:
    if not len(points_mm):
        return float("nan")
    return float(np.median(np.linalg.norm(cam.project(points_mm) - uv_px, axis=-1)))


@dataclass(frozen=True, eq=False)
class _Evidence:
    points_mm: np.ndarray  # (N, 3)
    uv_px: np.ndarray  # (N, 2)
    frame: np.ndarray  # (N,) frame index in the used frames


def _evidence(det: MultiViewKeypoints, c: int, loo: np.ndarray, cam: Camera, config: RigCheckConfig) -> _Evidence:
    kp = det.one_person[c]
    ok = det.confident(config.min_confidence)[c, :, 0] & np.isfinite(loo).all(-1)
    ok &= cam.depth_mm(np.nan_to_num(loo)) > 0
    t_idx, _ = np.nonzero(ok)
    return _Evidence(loo[ok], kp[ok][:, :2], t_idx)


def _judge(cam: Camera, ev: _Evidence, points_all: np.ndarray, uv_all: np.ndarray, expected: float | None,
           num_frames: int, config: RigCheckConfig, reference: CameraCheck | None = None) -> CameraCheck:
    """One camera's check; with ``reference`` (the same camera's check on a trial with the calibration as
    is, judged) the field, rotation and shift are the change since that trial, and the field's standard
    error includes the reference's."""
    n = len(ev.points_mm)
    if n < config.min_points:
        nan = float("nan")
        return CameraCheck(cam.name, False, n, _median_error(cam, ev.points_mm, ev.uv_px),
                           _median_error(cam, points_all, uv_all), nan, expected, nan, nan, nan, nan, False)
    fit = refit_pose(cam, ev.points_mm, ev.uv_px, scale_px=config.robust_scale_px)
    base = _reference_fit(reference)
    field = _field_px(cam, fit, ev.points_mm, base)
    block = np.minimum((ev.frame * config.blocks) // max(num_frames, 1), config.blocks - 1)
    jackknife = []
    for b in range(config.blocks):
        sel = block != b
        part = refit_pose(cam, ev.points_mm[sel], ev.uv_px[sel], scale_px=config.robust_scale_px)
        jackknife.append(_project_moved(cam, np.r_[rvec_of(part.turn), part.shift_mm], ev.points_mm))
    se = float(np.hypot(_field_se_px(jackknife), reference.field_se_px if reference is not None else 0.0))
    refit_cam = fit.apply(cam)
    change = PoseFit(fit.turn @ base.turn.T, fit.shift_mm - base.shift_mm)
    rot_res, shift_res = fit.resolution()
    if reference is not None:  # the change is only as well determined as the less determined of the two trials
        rot_res = np.maximum(rot_res, reference.resolution_deg_per_px)
        shift_res = max(shift_res, reference.resolution_mm_per_px)
    big = change.rotation_deg >= config.min_rotation_deg or float(np.linalg.norm(change.shift_mm)) >= config.min_shift_mm
    moved = bool(field >= config.min_field_px and field >= config.significance * se and big)  # rig_ratio: later
    return CameraCheck(
        cam.name, True, n, _median_error(cam, ev.points_mm, ev.uv_px), _median_error(cam, points_all, uv_all),
        _median_error(refit_cam, ev.points_mm, ev.uv_px), expected, field, se, change.rotation_deg,
        float(np.linalg.norm(change.shift_mm)), moved, tuple(float(v) for v in np.degrees(rvec_of(change.turn))),
        tuple(float(v) for v in change.shift_mm), resolution_deg_per_px=tuple(float(v) for v in rot_res),
        resolution_mm_per_px=float(shift_res),
    )


def _reference_fit(reference: CameraCheck | None) -> PoseFit:
    """The pose offset (turn, shift) a camera showed on the reference trial; none without one."""
    if reference is None:
        return PoseFit(np.eye(3), np.zeros(3))
    return PoseFit(rodrigues_batch(np.radians(np.asarray(reference.turn_deg, dtype=np.float64))),
                   np.asarray(reference.shift_vector_mm, dtype=np.float64))


def _field_se_px(jackknife: list[np.ndarray]) -> float:
    """Delete-one-block jackknife standard error (px) of the field from the fields (each (N, 2) px) refitted
    without one block of frames each: the median over the points."""
    stack = np.stack(jackknife)  # (B, N, 2)
    b = len(jackknife)
    spread = np.sqrt((b - 1) / b * np.sum((stack - stack.mean(0)) ** 2, axis=(0, 2)))  # (N,)
    return float(np.median(spread))


def _all_points(det: MultiViewKeypoints, c: int, points_mm: np.ndarray, config: RigCheckConfig):
    ok = det.confident(config.min_confidence)[c, :, 0] & np.isfinite(points_mm).all(-1)
    return points_mm[ok], det.one_person[c][ok][:, :2]


class _Judge:
    """Judges cameras against points triangulated without them and without the cameras already flagged."""

    def __init__(self, det: MultiViewKeypoints, rig: Rig, points_mm: np.ndarray, expected: dict[str, float],
                 config: RigCheckConfig, reference: _Judge | None = None):
        self.det, self.rig, self.points_mm, self.expected = det, rig, points_mm, expected
        self.num_frames, self.config, self.reference = det.shape[1], config, reference
        self.final: dict[int, CameraCheck] = {}

    def one(self, c: int, left_out: list[int]) -> CameraCheck:
        """Camera ``c`` judged against the points of the cameras other than it and ``left_out``; with a
        reference trial, against the field it showed there with the same cameras left out."""
        cam = self.rig[c]
        loo = _loo_points(self.det, self.rig, left_out + [c], self.config)
        ev = _evidence(self.det, c, loo, cam, self.config)
        pts_all, uv_all = _all_points(self.det, c, self.points_mm, self.config)
        ref = self.reference.one(c, left_out) if self.reference is not None else None
        usable = ref if ref is not None and ref.judged and _has_field(ref, self.config) else None
        chk = _judge(cam, ev, pts_all, uv_all, self.expected.get(cam.name), self.num_frames, self.config, usable)
        if ref is None:
            return chk
        how = COMPARED if usable is not None else NOT_JUDGED_THERE if not ref.judged else NO_FIELD_THERE
        return replace(chk, baseline=how)

    def all_but(self, left_out: list[int]) -> dict[int, CameraCheck]:
        """Every camera but ``left_out`` judged without them; {} where too few cameras are left: 2 views
        to triangulate on the first pass, ``config.rejudge_views`` once a camera is flagged."""
        views = self.config.rejudge_views if left_out else 2
        if len(self.rig) - len(left_out) - 1 < views:
            return {}
        return {c: self.one(c, left_out) for c in range(len(self.rig)) if c not in left_out}


def check_rig(detections: MultiViewKeypoints, rig: Rig, points_mm: np.ndarray, *,
              expected_px: Mapping[str, float] | None = None, baseline: MultiViewKeypoints | None = None,
              config: RigCheckConfig = RigCheckConfig()) -> RigCheck:
    """Check every camera of ``rig`` against the patient seen in ``detections`` (C, T, J, 3) px.

    ``points_mm`` (T, J, 3) mm: the trial's triangulated points (all cameras), used for the trial's own
    reprojection figure per camera. ``expected_px``: the calibration's own reprojection figure per camera
    name (px), reported beside the trial's. ``baseline``: the patient's detections (C', T', J, 3) px of a
    reference trial recorded with the calibration as is (no camera moved since; the same cameras and
    keypoint layout): each camera is then judged by the change of its field since that trial (the
    reference judged with the same cameras left out), so a field the detector's bias leaves with the calibration as is
    (real detectors place joints differently in each view) is not taken for a move; the estimated rotation
    and shift are the change since the reference. Needs at least 3 cameras (2 to triangulate without the one
    judged); ValueError naming what is wrong otherwise.
    """
    det, sub = detections.aligned_to(rig)
    c_count, t_count, _, j_count = det.shape
    points_mm = np.asarray(points_mm, dtype=np.float64)
    if points_mm.shape != (t_count, j_count, 3):
        raise ValueError(f"rig check: points_mm must be (T, J, 3) = ({t_count}, {j_count}, 3), got {points_mm.shape}")
    if c_count < 3:
        raise ValueError(f"rig check: needs at least 3 cameras (2 besides the one judged), got {list(det.camera_names)}")
    frames = checked_frames(t_count, config.max_frames)
    det = det.frames(frames)
    points_mm = points_mm[frames]
    expected = dict(expected_px or {})
    judge = _Judge(det, sub, points_mm, expected, config, _reference_judge(baseline, sub, j_count, config))
    flagged: list[int] = []
    current = judge.all_but(flagged)
    while True:
        candidates = [c for c, chk in current.items() if chk.moved]
        if not candidates:
            break
        worst = max(candidates, key=lambda c: current[c].field_px / max(current[c].field_se_px, 1e-9))
        others = judge.all_but(flagged + [worst]) or {c: replace(chk, moved=False)
                                                      for c, chk in current.items() if c != worst}
        typical = float(np.median([o.field_px for o in others.values() if o.judged] or [0.0]))
        if current[worst].field_px < config.rig_ratio * typical:  # does not stand out from the rest
            current = {c: replace(chk, moved=False) for c, chk in current.items()}
            break
        log.info("rig check: camera %s moved (field %.1f px, the others' %.1f px)", sub[worst].name,
                 current[worst].field_px, typical)
        flagged.append(worst)
        judge.final[worst] = current[worst]
        current = others
    judge.final.update({c: replace(chk, moved=False) if chk.moved else chk for c, chk in current.items()})
    cams = _with_floor(tuple(judge.final[c] for c in range(c_count)))
    return RigCheck(cams, tuple(_warning(chk) for chk in cams if chk.moved) + _unjudged(cams) + _without_baseline(cams))


def _with_floor(cams: tuple[CameraCheck, ...]) -> tuple[CameraCheck, ...]:
    """The checks with the floor set: the median field (px) of the judged cameras not flagged (of all judged
    cameras when every one is flagged), or the camera's own field's standard error where that is larger (a
    refit the trial's frames do not pin down: on an unmoved synthetic camera, 12 px +- 13 px with a
    1.8 deg turn)."""
    still = [c.field_px for c in cams if c.judged and not c.moved] or [c.field_px for c in cams if c.judged]
    floor = float(np.median(still)) if still else float("nan")
    return tuple(replace(c, floor_px=max(floor, c.field_se_px)) if c.judged else c for c in cams)


def _reference_judge(baseline: MultiViewKeypoints | None, rig: Rig, trial_joints: int,
                     config: RigCheckConfig) -> _Judge | None:
    """The judge of the reference trial with the trial's cameras ``rig`` (its own triangulated points,
    its frames thinned alike); None without one. ValueError naming what differs when it lacks a camera of
    the trial or has another keypoint count."""
    if baseline is None:
        return None
    names = list(baseline.camera_names)
    missing = [n for n in rig.names if n not in names]
    if missing:
        raise ValueError(f"rig check: the baseline trial lacks camera(s) {missing} of the trial (it has {names})")
    if baseline.shape[3] != trial_joints:
        raise ValueError(f"rig check: the baseline trial has {baseline.shape[3]} keypoints per person, the trial "
                         f"{trial_joints}")
    order = [names.index(n) for n in rig.names]
    det = MultiViewKeypoints.of_one_person(baseline.one_person[order], tuple(rig.names), baseline.times_s, baseline.skeleton)
    det = det.frames(checked_frames(det.shape[1], config.max_frames))
    points = robust_triangulate(det, rig).points_mm
    return _Judge(det, rig, points, {}, config)


def _warning(chk: CameraCheck) -> str:
    promised = f", the calibration promised {chk.expected_px:.2f} px" if chk.expected_px is not None else ""
    return (f"Camera {chk.name} appears to have moved since calibration: about {chk.rotation_deg:.1f} deg of "
            f"rotation and {chk.shift_mm:.0f} mm of shift ({_bounds_text(chk)}); its keypoints sit {chk.field_px:.1f} px off the other "
            f"cameras' points in a consistent direction (median error {chk.residual_px:.1f} px, "
            f"{chk.refit_residual_px:.1f} px once refitted{promised}). Recalibrate or refine the rig before "
            f"the next patient.")


def _bounds_text(chk: CameraCheck) -> str:
    """How well the trial determines the estimate, in words."""
    tilt, pan, roll = chk.rotation_bound_deg
    return (f"this trial determines the rotation to within {max(tilt, pan):.1f} deg in pan and tilt and "
            f"{roll:.1f} deg about the optical axis, the shift to within {chk.shift_bound_mm:.0f} mm")


def _without_baseline(cams: tuple[CameraCheck, ...]) -> tuple[str, ...]:
    names = [c.name for c in cams if c.judged and c.baseline == NOT_JUDGED_THERE]
    if not names:
        return ()
    return (f"Rig check: camera(s) {', '.join(names)} saw too few of the patient's keypoints in the baseline "
            "trial: judged without it (a field the detector leaves with the calibration as is may then be "
            "taken for a move).",)


def _unjudged(cams: tuple[CameraCheck, ...]) -> tuple[str, ...]:
    names = [c.name for c in cams if not c.judged]
    if not names:
        return ()
    return (f"Rig check: camera(s) {', '.join(names)} saw too few of the patient's keypoints to be checked.",)
