"""Kinematic walker: Halpe-26 joint trajectories (mm) of one rigid body following a footstep plan.

Feet are rigid bodies (heel, ankle, big toe, small toe) that land and leave like real feet (see
:mod:`gaitcap.simulator.foot` for the kinematics and their sources):
  - land heel first with the toes up, flat, or toe first (``heel_strike_angle_deg``), still moving
    forward: the contact point travels ``heel_roll_mm`` more while the foot rolls down to foot flat,
  - stay flat (the heel keypoint at rest from foot flat), then roll about the stationary big toe (heel
    rise) until toe-off,
  - swing to the next contact (a brisk start, a clearance lift, and the landing velocity at the end).
The pelvis follows anchor points derived from the feet (midway between the landing heel and the trailing
toe at each heel strike, shifted towards the stance foot in mid single support); its height is the
highest the legs reach (soft minimum over both legs), which gives the inverted-pendulum bounce. Knees come
from two-link inverse kinematics (rigid thigh and shank), arms from a swing angle coupled to the opposite
leg (rigid upper arm and forearm); trunk and head are rigid and follow the walking direction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.skeletons import get_skeleton
from gaitcap.simulator.foot import landing_speed_mm_s, landing_term, rolled_back
from gaitcap.simulator.params import WalkParams
from gaitcap.simulator.path import LEFT, RIGHT, FootPlan, forward, left_normal, wrap_angle
from scipy.interpolate import PchipInterpolator

SKELETON = get_skeleton("halpe26")
J = SKELETON.index
SIDE_NAMES = {LEFT: "left", RIGHT: "right"}


def min_jerk(tau):
    tau = np.clip(tau, 0.0, 1.0)
    return tau**3 * (10 - 15 * tau + 6 * tau**2)


def swing_profile(tau):
    """0 -> 1 with zero speed at both ends: a quick start after toe-off (the foot leaves briskly) and a
    minimum-jerk-like finish (speed ~ (1 - tau)^2) into heel strike. s' = 12 tau (1 - tau)^2."""
    tau = np.clip(tau, 0.0, 1.0)
    return 1.0 - (1.0 - tau) ** 3 * (1.0 + 3.0 * tau)


EARLY_LIFT_PEAK = 0.25  # fraction of the swing where the heel's extra lift peaks


def early_bump(tau):
    """0 -> 1 -> 0 over the swing, peaking at :data:`EARLY_LIFT_PEAK` (zero speed at both ends): real heels
    keep rising after toe off, highest at about 70 % of the stride, a quarter into the swing (the healthy
    motion-capture walk of ``mocap.py``: heel 270 mm up; the knee's flexion in swing follows the lift)."""
    tau = np.clip(tau, 0.0, 1.0)
    a, b = 2.0, 2.0 * (1.0 - EARLY_LIFT_PEAK) / EARLY_LIFT_PEAK
    peak = EARLY_LIFT_PEAK**a * (1.0 - EARLY_LIFT_PEAK) ** b
    return tau**a * (1.0 - tau) ** b / peak


@dataclass(frozen=True)
class Body:
    """Segment lengths (mm) of one person, from height with anthropometric ratios unless overridden."""

    height: float
    thigh: float
    shank: float
    upper_arm: float
    forearm: float
    foot: float  # heel -> big toe keypoint
    hip_width: float
    shoulder_width: float
    pelvis_height: float  # standing height of the hip keypoints
    heel_height: float
    toe_height: float
    ankle_height: float
    ankle_forward: float
    trunk: float  # pelvis -> neck
    toe_medial: float
    small_toe_lateral: float

    @classmethod
    def from_params(cls, p: WalkParams) -> Body:
        h = p.height_mm
        heel_h, ankle_h = 0.012 * h, 0.039 * h
        thigh = p.thigh_mm or 0.245 * h
        shank = p.shank_mm or 0.246 * h
        pelvis_h = ankle_h + thigh + shank
        return cls(
            height=h, thigh=thigh, shank=shank,
            upper_arm=p.upper_arm_mm or 0.186 * h, forearm=p.forearm_mm or 0.146 * h,
            foot=p.foot_mm or 0.140 * h, hip_width=p.hip_width_mm or 0.15 * h,
            shoulder_width=p.shoulder_width_mm or 0.22 * h, pelvis_height=pelvis_h,
            heel_height=heel_h, toe_height=0.010 * h, ankle_height=ankle_h, ankle_forward=0.03 * h,
            trunk=0.82 * h - pelvis_h + 0.02 * h, toe_medial=0.012 * h, small_toe_lateral=0.028 * h,
        )

    def foot_points(self, side: int) -> np.ndarray:
        """(4, 3) heel, ankle, big toe, small toe in the foot frame (x forward, y left, z up; heel origin)."""
        dz_toe = self.toe_height - self.heel_height
        return np.array([
            [0.0, 0.0, 0.0],
            [self.ankle_forward, 0.0, self.ankle_height - self.heel_height],
            [self.foot, -side * self.toe_medial, dz_toe],
            [0.78 * self.foot, side * self.small_toe_lateral, dz_toe],
        ])


def _foot_rot(yaw, pitch):
    """Rotation matrices (..., 3, 3): yaw about z, then pitch (toes up positive) about the foot's y axis."""
    yaw, pitch = np.broadcast_arrays(np.asarray(yaw, float), np.asarray(pitch, float))
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    # pitch: x -> (cos p, 0, sin p) (toes up), z -> (-sin p, 0, cos p)
    rp = np.zeros(yaw.shape + (3, 3))
    rp[..., 0, 0], rp[..., 0, 2] = cp, -sp
    rp[..., 1, 1] = 1.0
    rp[..., 2, 0], rp[..., 2, 2] = sp, cp
    rz = np.zeros(yaw.shape + (3, 3))
    rz[..., 0, 0], rz[..., 0, 1] = cy, -sy
    rz[..., 1, 0], rz[..., 1, 1] = sy, cy
    rz[..., 2, 2] = 1.0
    return rz @ rp


def foot_trajectory(plan: FootPlan, body: Body, params: WalkParams, side: int, times: np.ndarray) -> np.ndarray:
    """(T, 4, 3) heel, ankle, big toe, small toe of one foot."""
    pts = body.foot_points(side)
    toe_off = pts[2]
    th_hs = math.radians(params.side_heel_strike_angle_deg(SIDE_NAMES[side]))
    th_to = math.radians(params.toe_off_angle_deg)
    roll = params.heel_roll_mm
    contacts = plan.by_side(side)
    t = np.asarray(times, float)
    heel = np.zeros((t.size, 3))
    yaw = np.zeros(t.size)
    pitch = np.zeros(t.size)
    done = np.zeros(t.size, bool)

    def flat_heel(c):
        return np.array([c.heel_xy[0], c.heel_xy[1], body.heel_height])

    def ahead(c):
        return np.array([math.cos(c.heading), math.sin(c.heading), 0.0])

    def toe_fixed_heel(toe, yaw_c, p):
        """Heel position while the big toe is at ``toe`` and the foot pitched p."""
        return toe - (_foot_rot(np.full(np.shape(p), yaw_c), p) @ toe_off)

    def landing_heel(c, back, p):
        """Heel while landing: contact point ``back`` mm short of its rest, foot pitched p (about the heel
        when landing heel first or flat, about the big toe when landing toe first)."""
        shift = np.asarray(back)[..., None] * ahead(c)
        if th_hs >= 0:
            return flat_heel(c) - shift
        toe = flat_heel(c) + _foot_rot(c.heading, 0.0) @ toe_off - shift
        return toe_fixed_heel(toe, c.heading, p)

    for i, c in enumerate(contacts):
        nxt = contacts[i + 1] if i + 1 < len(contacts) else None
        h0 = flat_heel(c)
        # loading: the contact point rolls to rest, pitch th_hs -> 0
        m = (t >= c.t_hs) & (t < c.t_ff) & ~done
        if m.any():
            tau = (t[m] - c.t_hs) / (c.t_ff - c.t_hs)
            p = th_hs * (1 - min_jerk(tau))
            heel[m], yaw[m], pitch[m] = landing_heel(c, rolled_back(tau, roll), p), c.heading, p
            done |= m
        # flat
        m = (t >= c.t_ff) & (t < c.t_hr) & ~done
        heel[m], yaw[m], pitch[m] = h0, c.heading, 0.0
        done |= m
        if nxt is None:
            continue
        toe_rest = h0 + _foot_rot(c.heading, 0.0) @ toe_off
        # heel rise: rotate about the big toe, pitch 0 -> -th_to
        m = (t >= c.t_hr) & (t < c.t_to) & ~done
        if m.any():
            tau = (t[m] - c.t_hr) / (c.t_to - c.t_hr)
            p = -th_to * min_jerk(tau)
            heel[m], yaw[m], pitch[m] = toe_fixed_heel(toe_rest, c.heading, p), c.heading, p
            done |= m
        # swing: heel from its toe-off position to where it lands, arriving at the landing velocity
        m = (t >= c.t_to) & (t < nxt.t_hs) & ~done
        if m.any():
            swing_s = nxt.t_hs - c.t_to
            tau = (t[m] - c.t_to) / swing_s
            s = swing_profile(tau)[:, None]
            start = toe_fixed_heel(toe_rest, c.heading, -th_to)
            end = landing_heel(nxt, roll, th_hs)
            v_land = landing_speed_mm_s(roll, nxt.t_ff - nxt.t_hs) * ahead(nxt)
            hh = start * (1 - s) + end * s + landing_term(tau)[:, None] * (v_land * swing_s)
            hh[:, 2] += params.swing_lift_mm * early_bump(tau)
            dyaw = float(wrap_angle(nxt.heading - c.heading))
            heel[m], yaw[m] = hh, c.heading + dyaw * s[:, 0]
            pitch[m] = -th_to + (th_to + th_hs) * s[:, 0]
            done |= m
    if not done.all():
        raise AssertionError("foot trajectory: some times are not covered by the plan")
    rot = _foot_rot(yaw, pitch)
    return heel[:, None, :] + np.einsum("tij,kj->tki", rot, pts), yaw


def _pelvis_anchors(plan: FootPlan, body: Body, params: WalkParams):
    """Anchor times, pelvis ground positions (xy) and headings."""
    cs = plan.contacts
    toe_local = body.foot_points(LEFT)[2, :2]

    def toe_xy(c):
        ca, sa = math.cos(c.heading), math.sin(c.heading)
        local = np.array([toe_local[0], -c.side * body.toe_medial])
        return c.heel_xy + np.array([ca * local[0] - sa * local[1], sa * local[0] + ca * local[1]])

    def over_ankle(c):
        """Where the ankle keypoint stands (xy): standing upright, the hips are above the ankles."""
        return c.heel_xy + body.ankle_forward * np.array([math.cos(c.heading), math.sin(c.heading)])

    stand = [c for c in cs if c.kind == "stand"]
    centre0 = 0.5 * (over_ankle(stand[0]) + over_ankle(stand[1]))
    h0 = float(np.angle(np.exp(1j * stand[0].heading) + np.exp(1j * stand[1].heading)))
    times, xy, head = [-1e6], [centre0], [h0]
    steps = [k for k, c in enumerate(cs) if c.kind != "stand"]
    if not steps:
        times.append(1e6)
        xy.append(centre0)
        head.append(h0)
        return np.array(times), np.array(xy), np.array(head)
    times.append(plan.walk_start_s)
    xy.append(centre0)
    head.append(h0)
    hs_anchor = {}
    for k in steps:
        c, prev = cs[k], cs[k - 1]
        hs_anchor[k] = 0.5 * (c.heel_xy + toe_xy(prev))
    for k in steps:
        c, prev = cs[k], cs[k - 1]
        times.append(c.t_hs)
        xy.append(hs_anchor[k])
        hd = float(np.angle(np.exp(1j * c.heading) + np.exp(1j * prev.heading)))
        head.append(hd)
        # mid single support of foot k: between the other foot's toe-off and its next heel strike
        if k + 1 < len(cs) and k + 1 in hs_anchor and math.isfinite(prev.t_to):
            t_mid = 0.5 * (prev.t_to + cs[k + 1].t_hs)
            frac = (t_mid - c.t_hs) / (cs[k + 1].t_hs - c.t_hs)
            mid = (1 - frac) * hs_anchor[k] + frac * hs_anchor[k + 1]
            towards = c.heel_xy - mid
            lat = left_normal(hd)
            sway = params.pelvis_sway_mm * np.sign(float(towards @ lat)) * lat
            times.append(t_mid)
            xy.append(mid + sway)
            head.append(hd)
    last, before = cs[-1], cs[-2]
    end_centre = 0.5 * (over_ankle(last) + over_ankle(before))
    h_end = float(np.angle(np.exp(1j * last.heading) + np.exp(1j * before.heading)))
    for dt in (0.45, 1e6):
        times.append(last.t_hs + dt)
        xy.append(end_centre)
        head.append(h_end)
    order = np.argsort(times, kind="stable")
    times, xy, head = np.array(times)[order], np.array(xy)[order], np.array(head)[order]
    keep = np.concatenate([[True], np.diff(times) > 1e-6])
    return times[keep], xy[keep], np.unwrap(head[keep])


# The pelvis height is a soft minimum of what each leg reaches (its full length): the legs' shortfall bends
# the knees (a shortfall of d mm bends a leg of length L by about sqrt(8 d / L) rad: 1 mm, 5.5 deg).
# Walking, 1.5 mm; standing still, 0.05 mm: straight legs (1.0 deg). Before (6 mm, 99.5 % of the legs'
# length) the walker stood with its knees bent 16.5 deg (docs/kinematics.md).
SOFTMIN_WALK_MM = 1.5
SOFTMIN_STAND_MM = 0.05


def _softmin(values, k):
    v = np.stack(values)
    m = v.min(axis=0)
    return m - k * np.log(np.exp(-(v - m) / k).sum(axis=0))


def _two_link(hip, ankle, l1, l2, fwd):
    """Knee positions (T, 3) for a hip, ankle, thigh length l1, shank length l2, knee pointing along fwd."""
    d_vec = ankle - hip
    d = np.linalg.norm(d_vec, axis=-1, keepdims=True)
    if np.any(d > l1 + l2 + 1e-6):
        raise AssertionError(f"leg over-stretched by {float((d - l1 - l2).max()):.1f} mm")
    d = np.clip(d, abs(l1 - l2) + 1e-6, l1 + l2 - 1e-9)
    u = d_vec / d
    a = (l1**2 - l2**2 + d**2) / (2 * d)
    h = np.sqrt(np.clip(l1**2 - a**2, 0, None))
    perp = fwd - (fwd * u).sum(-1, keepdims=True) * u
    perp /= np.linalg.norm(perp, axis=-1, keepdims=True)
    return hip + a * u + h * perp


def simulate_body(plan: FootPlan, params: WalkParams, times: np.ndarray, body: Body | None = None) -> np.ndarray:
    """(T, 26, 3) Halpe-26 joint positions (mm) at ``times`` (s)."""
    body = body or Body.from_params(params)
    t = np.asarray(times, float)
    feet = {}
    feet_yaw = {}
    for side in (LEFT, RIGHT):
        feet[side], feet_yaw[side] = foot_trajectory(plan, body, params, side, t)
    a_t, a_xy, a_h = _pelvis_anchors(plan, body, params)
    if len(a_t) >= 2:
        pel_xy = np.stack([PchipInterpolator(a_t, a_xy[:, i])(t) for i in range(2)], -1)
        heading = PchipInterpolator(a_t, a_h)(t)
    else:
        pel_xy = np.repeat(a_xy[:1], t.size, 0)
        heading = np.full(t.size, a_h[0])
    fwd2 = np.stack([np.cos(heading), np.sin(heading)], -1)
    lat2 = np.stack([-np.sin(heading), np.cos(heading)], -1)
    L = params.step_length_mm
    ankle = {s: feet[s][:, 1] for s in (LEFT, RIGHT)}
    delta = ((ankle[LEFT][:, :2] - ankle[RIGHT][:, :2]) * fwd2).sum(-1)  # left ahead of right (mm)
    phase = np.tanh(delta / (0.5 * L))
    walking = np.clip(np.abs(delta) / (0.3 * L), 0, 1)
    rot_p = math.radians(params.pelvis_rotation_deg)
    pelvis_yaw = heading - rot_p * phase
    thorax_yaw = heading + 0.6 * rot_p * phase
    pl = np.stack([-np.sin(pelvis_yaw), np.cos(pelvis_yaw)], -1)
    hips_xy = {s: pel_xy + s * (body.hip_width / 2) * pl for s in (LEFT, RIGHT)}
    reach = body.thigh + body.shank
    limits = []
    for s in (LEFT, RIGHT):
        dxy2 = ((hips_xy[s] - ankle[s][:, :2]) ** 2).sum(-1)
        if np.any(dxy2 >= reach**2):
            raise AssertionError("walker: a foot lands out of reach of the hip (step too long for the legs)")
        limits.append(ankle[s][:, 2] + np.sqrt(reach**2 - dxy2))
    pel_z = _softmin([np.full(t.size, body.pelvis_height), *limits], k=SOFTMIN_WALK_MM * walking + SOFTMIN_STAND_MM)
    pelvis = np.concatenate([pel_xy, pel_z[:, None]], -1)
    out = np.zeros((t.size, 26, 3))
    out[:, J("pelvis")] = pelvis
    for s, name in ((LEFT, "left"), (RIGHT, "right")):
        hip = np.concatenate([hips_xy[s], pel_z[:, None]], -1)
        fy = feet_yaw[s]
        knee_fwd = np.stack([np.cos(fy), np.sin(fy), np.zeros_like(fy)], -1)
        knee = _two_link(hip, ankle[s], body.thigh, body.shank, knee_fwd)
        out[:, J(f"{name}_hip")] = hip
        out[:, J(f"{name}_knee")] = knee
        out[:, J(f"{name}_heel")] = feet[s][:, 0]
        out[:, J(f"{name}_ankle")] = feet[s][:, 1]
        out[:, J(f"{name}_big_toe")] = feet[s][:, 2]
        out[:, J(f"{name}_small_toe")] = feet[s][:, 3]
    # trunk: lean forward while walking
    lean = math.radians(params.trunk_lean_deg) * walking
    up = np.stack([np.sin(lean) * fwd2[:, 0], np.sin(lean) * fwd2[:, 1], np.cos(lean)], -1)
    neck = pelvis + body.trunk * up
    out[:, J("neck")] = neck
    tl = np.stack([-np.sin(thorax_yaw), np.cos(thorax_yaw), np.zeros_like(thorax_yaw)], -1)
    tf = np.stack([np.cos(thorax_yaw), np.sin(thorax_yaw), np.zeros_like(thorax_yaw)], -1)
    h = body.height
    shoulder_drop = 0.02 * h
    arm_amp = math.radians(params.arm_swing_deg)
    abd = math.radians(6.0)
    for s, name in ((LEFT, "left"), (RIGHT, "right")):
        sh = neck - shoulder_drop * up + s * (body.shoulder_width / 2) * tl
        alpha = -s * arm_amp * phase  # left arm forward when the right leg is forward
        elbow_dir = np.sin(alpha)[:, None] * math.cos(abd) * tf + s * math.sin(abd) * tl
        elbow_dir += (-np.cos(alpha) * math.cos(abd))[:, None] * np.array([0, 0, 1.0])
        elbow = sh + body.upper_arm * elbow_dir
        flex = math.radians(12.0) + 0.6 * np.clip(alpha, 0, None) + math.radians(8.0) * walking
        beta = alpha + flex
        wrist_dir = np.sin(beta)[:, None] * math.cos(abd) * tf + s * math.sin(abd) * tl
        wrist_dir += (-np.cos(beta) * math.cos(abd))[:, None] * np.array([0, 0, 1.0])
        out[:, J(f"{name}_shoulder")] = sh
        out[:, J(f"{name}_elbow")] = elbow
        out[:, J(f"{name}_wrist")] = elbow + body.forearm * wrist_dir
    # head: rigid, facing the walking direction
    hf = np.stack([fwd2[:, 0], fwd2[:, 1], np.zeros(t.size)], -1)
    hl = np.stack([lat2[:, 0], lat2[:, 1], np.zeros(t.size)], -1)
    zz = np.array([0, 0, 1.0])

    def head_pt(fw, lt, upv):
        return neck + fw * h * hf + lt * h * hl + upv * h * zz

    out[:, J("nose")] = head_pt(0.055, 0.0, 0.075)
    out[:, J("left_eye")] = head_pt(0.045, 0.018, 0.093)
    out[:, J("right_eye")] = head_pt(0.045, -0.018, 0.093)
    out[:, J("left_ear")] = head_pt(-0.005, 0.042, 0.085)
    out[:, J("right_ear")] = head_pt(-0.005, -0.042, 0.085)
    out[:, J("head")] = head_pt(0.0, 0.0, 0.16)
    return out


def limb_lengths(points_mm: np.ndarray) -> np.ndarray:
    """(T, n_limbs) lengths of the skeleton-loss limbs."""
    idx = np.array(SKELETON.limb_indices)
    return np.linalg.norm(points_mm[:, idx[:, 0]] - points_mm[:, idx[:, 1]], axis=-1)


__all__ = ["Body", "simulate_body", "foot_trajectory", "limb_lengths", "forward", "RIGHT", "LEFT"]
