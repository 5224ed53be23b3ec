"""Other people in the room: a therapist walking beside the patient, a bystander standing still."""

from __future__ import annotations

import math

import numpy as np
from gaitcap.simulator.params import WalkParams
from gaitcap.simulator.path import FootPlan, Room, plan_from_guide, plan_standing
from gaitcap.simulator.walker import SKELETON, Body, simulate_body

THERAPIST_OFFSET_MM = (-350.0, -650.0)  # (forward, left) of the patient's pelvis: behind and to the right
BYSTANDER_XY_MM = (2300.0, -2700.0)


def therapist_params(rng: np.random.Generator, patient: WalkParams) -> WalkParams:
    height = float(np.clip(rng.normal(1700.0, 70.0), 1550.0, 1900.0))
    return WalkParams(
        height_mm=height, step_length_mm=float(np.clip(0.37 * height, 520, 760)), step_width_mm=110.0,
        cadence_spm=float(np.clip(patient.cadence_spm * 1.02, 60, 150)), arm_swing_deg=12.0,
        lead_foot="left" if patient.lead_foot == "right" else "right",
    )


def therapist(
    rng: np.random.Generator, patient: WalkParams, patient_points: np.ndarray, times: np.ndarray, room: Room
) -> tuple[WalkParams, FootPlan, np.ndarray]:
    """A companion following the patient's pelvis path, behind and to its right (outside of the left turns)."""
    params = therapist_params(rng, patient)
    pel = patient_points[:, SKELETON.index("pelvis"), :2]
    lh, rh = patient_points[:, SKELETON.index("left_hip"), :2], patient_points[:, SKELETON.index("right_hip"), :2]
    lat = lh - rh
    heading = np.arctan2(-lat[:, 0], lat[:, 1])  # forward = left-normal rotated clockwise
    # smooth the heading (pelvis rotation oscillates) with a 1 s moving average on the unit circle
    k = max(1, int(round(1.0 / max(times[1] - times[0], 1e-3))))
    ker = np.ones(k) / k
    cs = np.convolve(np.pad(np.cos(heading), (k // 2, k - 1 - k // 2), mode="edge"), ker, "valid")
    sn = np.convolve(np.pad(np.sin(heading), (k // 2, k - 1 - k // 2), mode="edge"), ker, "valid")
    heading = np.arctan2(sn, cs)
    fwd = np.stack([np.cos(heading), np.sin(heading)], -1)
    left = np.stack([-np.sin(heading), np.cos(heading)], -1)
    guide = pel + THERAPIST_OFFSET_MM[0] * fwd + THERAPIST_OFFSET_MM[1] * left
    guide = np.clip(guide, -room.half + 350.0, room.half - 350.0)
    speed = np.linalg.norm(np.gradient(pel, times, axis=0), axis=-1)
    moving = speed > 150.0
    plan = plan_from_guide(params, times, guide, heading, moving, float(times[-1] - times[0]), phase_s=0.25)
    pts = simulate_body(plan, params, times, Body.from_params(params))
    return params, plan, pts


def bystander(rng: np.random.Generator, times: np.ndarray) -> tuple[WalkParams, FootPlan, np.ndarray]:
    """Someone standing in the room (near a wall, facing the walkway), swaying a little."""
    height = float(np.clip(rng.normal(1680.0, 80.0), 1500.0, 1950.0))
    params = WalkParams(height_mm=height, step_length_mm=600.0, arm_swing_deg=5.0)
    xy = np.array(BYSTANDER_XY_MM) + rng.uniform(-200, 200, 2)
    heading = math.atan2(-xy[1], -xy[0]) + rng.uniform(-0.3, 0.3)
    plan = plan_standing(params, xy, heading, float(times[-1] - times[0]))
    pts = simulate_body(plan, params, times, Body.from_params(params))
    # idle sway: slow weight shifts of the upper body (feet stay planted; rigid limbs kept by moving the
    # whole upper body together, hips included, is not possible, so only the head/arms/trunk sway)
    sway = 15.0 * np.sin(2 * np.pi * 0.23 * times + rng.uniform(0, 6.3))
    upper = [SKELETON.index(n) for n in SKELETON.joint_names if not any(
        k in n for k in ("hip", "knee", "ankle", "heel", "toe", "pelvis"))]
    direction = np.array([math.cos(heading + math.pi / 2), math.sin(heading + math.pi / 2), 0.0])
    pts[:, upper] += sway[:, None, None] * direction
    return params, plan, pts
