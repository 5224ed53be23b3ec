"""Joint angles fitted directly to the 2D keypoints (JAX): a lower-body chain whose per-frame joint angles
and fixed segment lengths are optimised so that its hips, knees, ankles, heels and toes, projected through
the calibrated cameras, land on the detections (robust Huber loss, confidence-weighted, smooth over time).

Chain (pelvis frame: x forward, y left, z up; metres and radians inside, mm and degrees outside):
- pelvis: position of the hips' midpoint, heading (about z) and obliquity (about x); no tilt (the hips
  alone cannot fix it);
- hip: flexion, adduction, rotation (the thigh from the hip joint centre down); knee: flexion; ankle:
  dorsiflexion; the foot is rigid: heel, big toe and small toe offsets from the ankle, fitted per side.
The angles reported are measured on the fitted chain's points with
:func:`gaitcap.reconstruction.kinematics.geometric.keypoint_angles`, so they compare with the same angles of
any 3D keypoints (the synthetic walker's truth, a 3D fit).
"""

from __future__ import annotations

from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.fits.optim import LBFGS, Adam, WarmupHoldDecay
from gaitcap.reconstruction.kinematics.geometric import keypoint_angles
from gaitcap.reconstruction.losses import LossConfig, Observations, huber, make_observations
from gaitcap.reconstruction.projection import CameraArrays, camera_arrays, project

SIDES = (("left", 1.0), ("right", -1.0))
PARTS = ("hip", "knee", "ankle", "heel", "big_toe", "small_toe")
JOINTS = tuple(f"{side}_{p}" for side, _ in SIDES for p in PARTS)  # what the chain produces
ANGLES = ("flex", "add", "rot", "knee", "ankle")  # per side and frame, radians
FOOT0_M = np.array([[-0.05, 0.0, -0.07], [0.15, -0.02, -0.07], [0.13, 0.03, -0.07]])  # heel, big, small toe (left)


@dataclass(frozen=True)
class Fit2DConfig:
    """steps and learning_rate of Adam (metres and radians; decaying exponentially to
    final_learning_rate over the second half of the steps), then lbfgs_iterations of L-BFGS; smooth_weight: the squared second
    difference of the per-frame parameters (per frame^2) against the mean Huber loss (px^2); gamma:
    views at or below this confidence are not used; huber_delta_px and cut_px: the robust loss's shape
    (as the default 3D fit's)."""

    steps: int = 1500
    learning_rate: float = 0.01
    final_learning_rate: float = 1e-4
    lbfgs_iterations: int = 0
    smooth_weight: float = 30.0
    gamma: float = 0.5
    huber_delta_px: float = 5.0
    cut_px: float | None = 10.0


def _rot(axis: int, a: jnp.ndarray) -> jnp.ndarray:
    c, s, z, o = jnp.cos(a), jnp.sin(a), jnp.zeros_like(a), jnp.ones_like(a)
    rows = {0: ((o, z, z), (z, c, -s), (z, s, c)), 1: ((c, z, s), (z, o, z), (-s, z, c)),
            2: ((c, -s, z), (s, c, z), (z, z, o))}[axis]
    return jnp.stack([jnp.stack(r, -1) for r in rows], -2)


def chain_points(params: dict) -> jnp.ndarray:
    """(T, 12, 3) mm points of :data:`JOINTS` from the chain's parameters."""
    pelvis = _rot(2, params["yaw"]) @ _rot(0, params["roll"])  # (T, 3, 3)
    out = []
    for k, (_, s) in enumerate(SIDES):
        a = params["angles"][:, k]  # (T, 5)
        hip = params["root"] + pelvis @ jnp.array([0.0, s * 0.5, 0.0]) * params["width"]
        thigh = pelvis @ _rot(1, -a[:, 0]) @ _rot(0, -s * a[:, 1]) @ _rot(2, s * a[:, 2])
        knee = hip + thigh[..., 2] * -params["lengths"][k, 0]
        shank = thigh @ _rot(1, a[:, 3])
        ankle = knee + shank[..., 2] * -params["lengths"][k, 1]
        foot = shank @ _rot(1, -a[:, 4])
        feet = ankle[:, None] + jnp.einsum("tij,pj->tpi", foot, params["foot"][k])
        out += [hip[:, None], knee[:, None], ankle[:, None], feet]
    return 1000.0 * jnp.concatenate(out, axis=1)


def _objective(cfg: Fit2DConfig):
    loss_cfg = LossConfig(huber_delta_px=cfg.huber_delta_px, cut_px=cfg.cut_px)

    def objective(params, data, reg):
        obs, cams = data
        pts = chain_points(params)  # (T, J, 3)
        u, v = project(jnp.transpose(pts, (2, 0, 1)).reshape(3, -1), cams)
        h = huber((u - obs.u_px) ** 2 + (v - obs.v_px) ** 2, loss_cfg)
        fit = jnp.sum(obs.weight * h) / jnp.maximum(jnp.sum(obs.weight), 1e-9)
        per_frame = jnp.concatenate([params["root"], params["yaw"][:, None], params["roll"][:, None],
                                     params["angles"].reshape(params["angles"].shape[0], -1)], axis=1)
        smooth = jnp.mean(jnp.sum((per_frame[2:] - 2 * per_frame[1:-1] + per_frame[:-2]) ** 2, axis=1))
        return fit + cfg.smooth_weight * smooth, (fit, smooth)

    return objective


def initial_params(points_mm: np.ndarray, joint_names) -> dict:
    """Chain parameters from gap-free 3D keypoints (T, J, 3) mm (e.g. a triangulation): root, heading, lengths
    and hip, knee and ankle angles measured on them; hip rotation 0; generic foot offsets."""
    names = [str(n) for n in joint_names]
    missing = [j for j in JOINTS if j not in names]
    if missing:
        raise ValueError(f"joint_names: the chain needs {missing}")
    pts = np.asarray(points_mm, dtype=np.float64)[:, [names.index(j) for j in JOINTS]] / 1000.0
    if not np.isfinite(pts).all():
        raise ValueError("initial 3D points: gaps in the lower body (fill them first: fits.common.fill_gaps)")
    j = {n: pts[:, i] for i, n in enumerate(JOINTS)}
    across = j["left_hip"] - j["right_hip"]
    ang = keypoint_angles(pts * 1000.0, JOINTS)
    per_side = [np.stack([np.radians(ang["hip_flexion"][s]), np.radians(ang["hip_adduction"][s]),
                          np.zeros(len(pts)), np.radians(ang["knee_flexion"][s]),
                          np.radians(ang["ankle_dorsiflexion"][s])], axis=1) for s, _ in SIDES]
    seg = lambda a, b: float(np.median(np.linalg.norm(j[a] - j[b], axis=1)))  # noqa: E731
    return {"root": jnp.asarray(0.5 * (j["left_hip"] + j["right_hip"]), jnp.float32),
            "yaw": jnp.asarray(np.unwrap(np.arctan2(-across[:, 0], across[:, 1])), jnp.float32),
            "roll": jnp.asarray(np.arcsin(np.clip(across[:, 2] / np.linalg.norm(across, axis=1), -1, 1)), jnp.float32),
            "angles": jnp.asarray(np.stack(per_side, axis=1), jnp.float32),
            "width": jnp.asarray(float(np.median(np.linalg.norm(across, axis=1))), jnp.float32),
            "lengths": jnp.asarray([[seg(f"{s}_hip", f"{s}_knee"), seg(f"{s}_knee", f"{s}_ankle")] for s, _ in SIDES],
                                   jnp.float32),
            "foot": jnp.asarray(np.stack([FOOT0_M * [1.0, s, 1.0] for _, s in SIDES]), jnp.float32)}


@dataclass(frozen=True, eq=False)
class Fit2DResult:
    """points_mm (T, 12, 3) of :data:`JOINTS`; angles_deg: variable -> side -> (T,) (geometric definitions);
    loss: final mean Huber reprojection loss (px^2 units); seconds: optimisation time."""

    points_mm: np.ndarray
    angles_deg: dict[str, dict[str, np.ndarray]]
    loss: float
    seconds: float


def _check_shapes(kp_shape: tuple, camera_names: tuple, init_shape: tuple, joints: int) -> None:
    """ValueError naming the argument whose shape does not match: keypoints (C, T, J, 3) against the
    C ``camera_names``, the J ``joint_names`` and the T frames of ``init_points_mm`` (T, J, 3)."""
    if len(kp_shape) != 4 or kp_shape[3] != 3:
        raise ValueError(f"keypoints: expected (cameras, frames, joints, 3), got shape {kp_shape}")
    if kp_shape[0] != len(camera_names):
        raise ValueError(f"keypoints: {kp_shape[0]} cameras but camera_names has {len(camera_names)} "
                         f"({list(camera_names)})")
    if len(set(camera_names)) != len(camera_names):
        raise ValueError(f"camera_names: a camera is named twice ({list(camera_names)})")
    if kp_shape[2] != joints:
        raise ValueError(f"keypoints: {kp_shape[2]} joints but joint_names has {joints}")
    if init_shape[:2] != (kp_shape[1], joints):
        raise ValueError(f"init_points_mm: shape {init_shape} does not match the keypoints' {kp_shape[1]} frames "
                         f"x {joints} joints")


def fit_angles_2d(keypoints: np.ndarray, joint_names, rig: Rig, camera_names, init_points_mm: np.ndarray, *,
                  weights: np.ndarray | None = None, config: Fit2DConfig = Fit2DConfig()) -> Fit2DResult:
    """Fit the chain to 2D keypoints (C, T, J, 3: px, px, confidence) of the cameras ``camera_names`` of
    ``rig``, starting from 3D keypoints ``init_points_mm`` (T, J, 3) of the same layout (gap-free).
    ``weights`` (C, T, J): each view's weight (e.g. the robust triangulation's); the confidences without."""
    import time

    names = [str(n) for n in joint_names]
    params = initial_params(init_points_mm, names)  # first: names the joints the chain lacks
    idx = [names.index(j) for j in JOINTS]
    _check_shapes(np.shape(keypoints), tuple(camera_names), np.shape(init_points_mm), len(names))
    kp = np.asarray(keypoints, dtype=np.float64)[:, :, idx]
    conf = np.nan_to_num(kp[..., 2])
    w = conf if weights is None else np.nan_to_num(np.asarray(weights, dtype=np.float64)[:, :, idx])
    obs: Observations = make_observations(kp, np.where(conf > config.gamma, w, 0.0))
    cams: CameraArrays = camera_arrays(rig.subset(tuple(camera_names)))
    t0 = time.perf_counter()
    lr = WarmupHoldDecay(init=config.learning_rate, peak=config.learning_rate, warmup_steps=1,
                         decay_start=config.steps // 2, end=config.final_learning_rate, total_steps=config.steps)
    params, _ = Adam(learning_rate=lr, steps=config.steps).minimize(_objective(config), params, (obs, cams))
    if config.lbfgs_iterations:
        params, _ = LBFGS(iterations=config.lbfgs_iterations).minimize(_objective(config), params, (obs, cams))
    pts = np.asarray(jax.block_until_ready(chain_points(params)), dtype=np.float64)
    seconds = time.perf_counter() - t0
    _, (fit, _) = _objective(config)(params, (obs, cams), 1.0)
    return Fit2DResult(pts, keypoint_angles(pts, JOINTS), float(fit), seconds)
