"""Detection noise: what a 2D keypoint detector makes of the projected ground truth.

For each camera, frame and joint the model produces (x px, y px, confidence):
- the ground truth at the camera's true capture time (nominal frame time + PTP clock offset + jitter),
  projected through the camera (OpenCV model with distortion);
- Gaussian pixel noise, heteroscedastic: its scale is a fraction of the person's apparent height (px), per
  joint group (feet and hands worse than the torso), times a log-normal per-keypoint factor (heavy tails),
  correlated over time (AR(1)), plus a constant per-camera/joint bias (detectors place a joint slightly
  differently in each view);
- occlusion: a joint hidden behind a body segment (of this person or another one) gets more noise and a
  lower confidence;
- out-of-image joints are clamped to the image border with a confidence near 0; a person mostly out of
  view (or missed) is not detected at all in that camera (NaN, confidence 0);
- outliers: a joint misplaced by 5-40 % of the body height, often with a confident score; left/right
  swaps of the legs (or of the whole body) lasting a few frames;
- confidences in [0, 1] that drop with the error actually made, so confidence and error are correlated.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.skeletons import get_skeleton
from gaitcap.simulator.room import visible
from scipy.signal import lfilter

SKELETON = get_skeleton("halpe26")
EXPOSURE_S = 0.015  # the lab's fixed exposure

# Joint groups and their noise multipliers / base confidences.
_GROUPS = {
    "head": ("nose", "left_eye", "right_eye", "left_ear", "right_ear", "head"),
    "torso": ("left_shoulder", "right_shoulder", "left_hip", "right_hip", "neck", "pelvis"),
    "elbow": ("left_elbow", "right_elbow"),
    "hand": ("left_wrist", "right_wrist"),
    "knee": ("left_knee", "right_knee"),
    "foot": ("left_ankle", "right_ankle", "left_heel", "right_heel", "left_big_toe", "right_big_toe",
             "left_small_toe", "right_small_toe"),
}
_GROUP_SIGMA = {"head": 0.8, "torso": 1.0, "elbow": 1.1, "hand": 1.5, "knee": 1.0, "foot": 1.35}
_GROUP_CONF = {"head": 0.90, "torso": 0.88, "elbow": 0.85, "hand": 0.80, "knee": 0.87, "foot": 0.80}
_HIP_JOINTS = ("hip", "pelvis")


def _per_joint(table: dict[str, float]) -> np.ndarray:
    out = np.ones(SKELETON.num_joints)
    for g, names in _GROUPS.items():
        for n in names:
            out[SKELETON.index(n)] = table[g]
    return out


JOINT_SIGMA = _per_joint(_GROUP_SIGMA)
JOINT_CONF = _per_joint(_GROUP_CONF)

# Capsules (joint a, joint b, radius as a fraction of body height) that can hide joints behind them.
CAPSULES = (
    ("pelvis", "neck", 0.085), ("left_hip", "left_knee", 0.040), ("right_hip", "right_knee", 0.040),
    ("left_knee", "left_ankle", 0.030), ("right_knee", "right_ankle", 0.030),
    ("left_shoulder", "left_elbow", 0.025), ("right_shoulder", "right_elbow", 0.025),
    ("left_elbow", "left_wrist", 0.020), ("right_elbow", "right_wrist", 0.020),
    ("neck", "head", 0.055),
)

LEG_SWAP = tuple(
    (SKELETON.index(f"left_{n}"), SKELETON.index(f"right_{n}"))
    for n in ("hip", "knee", "ankle", "heel", "big_toe", "small_toe")
)


@dataclass(frozen=True)
class NoisePreset:
    """One detector-quality setting (see the module docstring for the model).

    sigma_frac: per-coordinate noise sd of torso joints as a fraction of the apparent body height.
    sigma_min_px: noise floor (px). sigma_spread: log-normal sd of the per-keypoint noise factor.
    temporal_corr: AR(1) coefficient of the noise from frame to frame.
    bias_frac: sd of the constant per-camera/joint offset, fraction of body height.
    occluded_sigma_scale, occluded_conf_scale: extra noise and confidence factor of occluded joints.
    outlier_rate: probability that a keypoint is misplaced; outlier_frac: displacement range (fraction of
    body height). swap_rate: per camera and frame, chance a left/right swap starts; swap_frames: mean run.
    miss_rate: chance per camera and frame that the person is not detected at all.
    blur_frac: extra noise sd per px of motion blur (image-plane motion during the 15 ms exposure): fast
    feet in swing are detected worse.
    confusion_rate: chance that a joint hidden behind another person is detected on that person's
    same joint instead (when it lies within 15 % of the body height of it in the image).
    conf_sd: confidence noise; conf_error_slope: confidence lost per unit of (error / expected error).
    clock_offset_sd_ns, jitter_sd_ns: PTP clock offset per camera and per-frame jitter (|.| < 100 us).
    """

    name: str
    sigma_frac: float
    sigma_min_px: float
    sigma_spread: float
    temporal_corr: float
    bias_frac: float
    occlusion: bool
    occluded_sigma_scale: float
    occluded_conf_scale: float
    outlier_rate: float
    outlier_frac: tuple[float, float]
    swap_rate: float
    swap_frames: float
    miss_rate: float
    confusion_rate: float
    blur_frac: float
    conf_sd: float
    conf_error_slope: float
    clock_offset_sd_ns: float
    jitter_sd_ns: float

    def __post_init__(self) -> None:
        for f in ("sigma_frac", "sigma_min_px", "sigma_spread", "bias_frac", "outlier_rate", "swap_rate", "miss_rate",
                  "confusion_rate", "blur_frac",
                  "conf_sd", "conf_error_slope", "clock_offset_sd_ns", "jitter_sd_ns"):
            if getattr(self, f) < 0:
                raise ValueError(f"NoisePreset {self.name}: {f} must be >= 0")
        if not 0 <= self.temporal_corr < 1:
            raise ValueError(f"NoisePreset {self.name}: temporal_corr must be in [0, 1)")
        if self.outlier_rate > 0.5 or self.miss_rate > 0.5:
            raise ValueError(f"NoisePreset {self.name}: outlier_rate and miss_rate must be <= 0.5")
        if self.clock_offset_sd_ns * 3 > 100_000 or self.jitter_sd_ns * 3 > 100_000:
            raise ValueError(f"NoisePreset {self.name}: clock offsets must stay well below 100 us")


PRESETS: dict[str, NoisePreset] = {
    p.name: p
    for p in (
        NoisePreset(
            name="clean", sigma_frac=0.0, sigma_min_px=0.15, sigma_spread=0.0, temporal_corr=0.0, bias_frac=0.0,
            occlusion=False, occluded_sigma_scale=1.0, occluded_conf_scale=1.0, outlier_rate=0.0,
            outlier_frac=(0.05, 0.4), swap_rate=0.0, swap_frames=1.0, miss_rate=0.0, confusion_rate=0.0, blur_frac=0.0, conf_sd=0.02,
            conf_error_slope=0.0, clock_offset_sd_ns=2_000.0, jitter_sd_ns=1_000.0,
        ),
        NoisePreset(
            name="paper", sigma_frac=0.0062, sigma_min_px=0.8, sigma_spread=0.8, temporal_corr=0.5,
            bias_frac=0.0025, occlusion=True, occluded_sigma_scale=2.5, occluded_conf_scale=0.55,
            outlier_rate=0.085, outlier_frac=(0.05, 0.4), swap_rate=0.008, swap_frames=4.0, miss_rate=0.005,
            confusion_rate=0.3, blur_frac=0.3, conf_sd=0.06, conf_error_slope=0.08, clock_offset_sd_ns=15_000.0,
            jitter_sd_ns=8_000.0,
        ),
        NoisePreset(
            name="hard", sigma_frac=0.011, sigma_min_px=1.2, sigma_spread=0.9, temporal_corr=0.6,
            bias_frac=0.005, occlusion=True, occluded_sigma_scale=3.5, occluded_conf_scale=0.5,
            outlier_rate=0.15, outlier_frac=(0.05, 0.5), swap_rate=0.02, swap_frames=6.0, miss_rate=0.02,
            confusion_rate=0.5, blur_frac=0.45, conf_sd=0.1, conf_error_slope=0.06, clock_offset_sd_ns=25_000.0, jitter_sd_ns=15_000.0,
        ),
    )
}


def get_preset(name: str | NoisePreset) -> NoisePreset:
    if isinstance(name, NoisePreset):
        return name
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; choose one of {sorted(PRESETS)}")
    return PRESETS[name]


def clock_model(preset: NoisePreset, n_cameras: int, n_frames: int, rng: np.random.Generator):
    """Per-camera clock offsets (C,) and per-frame jitter (C, T), int64 ns, clipped to +-90 us."""
    off = np.clip(rng.normal(0, preset.clock_offset_sd_ns, n_cameras), -60_000, 60_000)
    jit = np.clip(rng.normal(0, preset.jitter_sd_ns, (n_cameras, n_frames)), -30_000, 30_000)
    return np.round(off).astype(np.int64), np.round(jit).astype(np.int64)


def _seg_seg_dist(p0, p1, q0, q1):
    """Distance between segments p0p1 and q0q1 (broadcast over leading axes) and the parameter s on p."""
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a = (d1 * d1).sum(-1)
    e = (d2 * d2).sum(-1)
    f = (d2 * r).sum(-1)
    c = (d1 * r).sum(-1)
    b = (d1 * d2).sum(-1)
    denom = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(denom > 1e-9, np.clip((b * f - c * e) / denom, 0, 1), 0.0)
        t = (b * s + f) / np.where(e > 1e-9, e, 1.0)
    t_c = np.clip(t, 0, 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(t != t_c, np.clip((b * t_c - c) / np.where(a > 1e-9, a, 1.0), 0, 1), s)
    closest = (p0 + s[..., None] * d1) - (q0 + t_c[..., None] * d2)
    return np.linalg.norm(closest, axis=-1), s


def occlusion_mask(rig: Rig, people_mm: np.ndarray, heights_mm: np.ndarray, person: int) -> np.ndarray:
    """(C, T, J) bool: joints of ``person`` hidden behind a capsule of any person (own adjacent ones excluded)."""
    n_people, t_len, j_len, _ = people_mm.shape
    target = people_mm[person]  # (T, J, 3)
    out = np.zeros((len(rig), t_len, j_len), bool)
    for ci, cam in enumerate(rig):
        c = cam.center_mm
        for p in range(n_people):
            for a_name, b_name, rad in CAPSULES:
                ia, ib = SKELETON.index(a_name), SKELETON.index(b_name)
                qa = people_mm[p, :, ia][:, None, :]
                qb = people_mm[p, :, ib][:, None, :]
                # shrink the segment ends a little so a joint does not hide behind its own segment's end
                dist, s = _seg_seg_dist(np.broadcast_to(c, target.shape), target, qa, qb)
                blocked = (dist < rad * heights_mm[p]) & (s < 0.97)
                if p == person:
                    blocked[:, [ia, ib]] = False
                    # joints adjacent along a limb (e.g. the ankle behind its own shank) are not hidden
                out[ci] |= blocked
    return out


def detect(
    rig: Rig,
    points_mm: np.ndarray,
    velocity_mm_s: np.ndarray,
    height_mm: float,
    preset: NoisePreset,
    time_offsets_s: np.ndarray,
    rng: np.random.Generator,
    occluded: np.ndarray | None = None,
    others_mm: np.ndarray | None = None,
) -> np.ndarray:
    """(C, T, J, 3) detections of one person. ``time_offsets_s`` (C, T): capture time minus frame time.

    ``others_mm`` (Q, T, J, 3): the other people, whose joints an occluded joint may be confused with.
    """
    t_len, j_len, _ = points_mm.shape
    c_len = len(rig)
    out = np.full((c_len, t_len, j_len, 3), np.nan)
    out[..., 2] = 0.0
    sig_j = JOINT_SIGMA
    for ci, cam in enumerate(rig):
        pts = points_mm + time_offsets_s[ci][:, None, None] * velocity_mm_s
        px, ok = visible(cam, pts)
        in_front = cam.depth_mm(pts) > 100.0
        # apparent height of the person (px) from the depth of the pelvis
        depth = np.maximum(cam.depth_mm(pts[:, SKELETON.index("pelvis")]), 300.0)
        size_px = cam.matrix_px[1, 1] * height_mm / depth  # (T,)
        sigma0 = np.maximum(preset.sigma_frac * size_px[:, None] * sig_j[None, :], preset.sigma_min_px)  # (T, J)
        if preset.blur_frac > 0:
            # image-plane motion during the exposure (px), from the 3D velocity
            px_next, _ = visible(cam, pts + EXPOSURE_S * velocity_mm_s)
            blur = np.nan_to_num(np.linalg.norm(px_next - px, axis=-1), nan=0.0, posinf=0.0)
            sigma0 = np.hypot(sigma0, preset.blur_frac * np.minimum(blur, 0.2 * size_px[:, None]))
        spread = np.exp(rng.normal(0, preset.sigma_spread, (t_len, j_len))) if preset.sigma_spread > 0 else 1.0
        occ = occluded[ci] if (occluded is not None and preset.occlusion) else np.zeros((t_len, j_len), bool)
        sigma = sigma0 * spread * np.where(occ, preset.occluded_sigma_scale, 1.0)
        white = rng.normal(0, 1, (t_len, j_len, 2))
        if preset.temporal_corr > 0:
            rho = preset.temporal_corr
            white = lfilter([math.sqrt(1 - rho**2)], [1, -rho], white, axis=0)
        err = white * sigma[..., None]
        bias = rng.normal(0, preset.bias_frac, (j_len, 2)) * size_px[:, None, None] * sig_j[None, :, None]
        err = err + bias
        det = px + err
        # expected error scale for the confidence
        err_norm = np.linalg.norm(err, axis=-1) / (sigma0 * 1.5 + 1e-9)
        conf = JOINT_CONF[None, :] - preset.conf_error_slope * err_norm + rng.normal(0, preset.conf_sd, (t_len, j_len))
        conf = np.where(occ, conf * preset.occluded_conf_scale, conf)
        # outliers: misplaced joints, often still confident
        if preset.outlier_rate > 0:
            is_out = rng.random((t_len, j_len)) < preset.outlier_rate
            mag = rng.uniform(*preset.outlier_frac, (t_len, j_len)) * size_px[:, None]
            ang = rng.uniform(0, 2 * np.pi, (t_len, j_len))
            shift = np.stack([np.cos(ang), np.sin(ang)], -1) * mag[..., None]
            det = np.where(is_out[..., None], det + shift, det)
            conf = np.where(is_out, rng.uniform(0.2, 0.95, (t_len, j_len)), conf)
        # identity confusion: a joint hidden behind someone else is detected on that person's joint
        if others_mm is not None and len(others_mm) and preset.confusion_rate > 0 and occ.any():
            best = np.full((t_len, j_len), np.inf)
            best_px = np.zeros((t_len, j_len, 2))
            for other in others_mm:
                opx, ook = visible(cam, other)
                dist = np.where(ook, np.linalg.norm(opx - px, axis=-1), np.inf)
                closer = dist < best
                best = np.where(closer, dist, best)
                best_px = np.where(closer[..., None], opx, best_px)
            confused = occ & (best < 0.15 * size_px[:, None]) & (rng.random((t_len, j_len)) < preset.confusion_rate)
            det = np.where(confused[..., None], best_px + rng.normal(0, 1, (t_len, j_len, 2)) * sigma0[..., None], det)
            conf = np.where(confused, rng.uniform(0.4, 0.9, (t_len, j_len)), conf)
        # left/right swaps (legs, sometimes the whole body) over runs of frames
        if preset.swap_rate > 0:
            starts = np.flatnonzero(rng.random(t_len) < preset.swap_rate)
            for s0 in starts:
                n = max(1, int(rng.geometric(1.0 / preset.swap_frames)))
                sl = slice(s0, min(t_len, s0 + n))
                pairs = LEG_SWAP if rng.random() < 0.75 else SKELETON.left_right_pairs
                for a, b in pairs:
                    det[sl, a], det[sl, b] = det[sl, b].copy(), det[sl, a].copy()
                    conf[sl, a], conf[sl, b] = conf[sl, b].copy(), conf[sl, a].copy()
        # out of the image: clamp to the border, confidence near zero
        w, h = cam.size_px
        outside = ~ok
        det[..., 0] = np.where(outside, np.clip(det[..., 0], 0, w - 1), det[..., 0])
        det[..., 1] = np.where(outside, np.clip(det[..., 1], 0, h - 1), det[..., 1])
        conf = np.where(outside, rng.uniform(0.0, 0.15, (t_len, j_len)), conf)
        conf = np.clip(conf, 0.0, 1.0)
        # person not detected: mostly out of view, behind the camera, or a random miss
        frac_in = ok.mean(axis=1)
        missed = (frac_in < 0.4) | ~in_front.any(axis=1)
        if preset.miss_rate > 0:
            missed |= rng.random(t_len) < preset.miss_rate
        bad = ~in_front  # a joint behind the camera has no meaningful position
        det = np.where(bad[..., None], np.nan, det)
        conf = np.where(bad, 0.0, conf)
        det[missed] = np.nan
        conf[missed] = 0.0
        out[ci, ..., :2] = det
        out[ci, ..., 2] = conf
    return out
