"""How real feet land and leave the floor: the contact kinematics the synthetic walker's feet follow.

Ground truth is defined as force plates define it: initial contact (heel strike) is the first instant of
ground contact, toe off the last. What the foot does around those instants:

- Landing (loading response, heel rocker). The foot reaches the floor still moving forward: the heel
  keypoint does not stop at contact but rolls over the rounded heel and comes to rest at foot flat, at
  about 8 % of the stride (Perry & Burnfield 2010, ch. 4; ``path.FOOT_FLAT_FRACTION``). Winter (1992)
  measured a clearly non-zero horizontal heel velocity at heel contact. In the real walks installed for the
  tests (``mocap.py``: Fukuchi et al. 2018, and a Parkinson walk), the heel marker moves at 0.2-1.0 m/s at
  the annotated contact and travels 10-45 mm to rest 60-130 ms later. The walker: the contact point keeps
  travelling ``WalkParams.heel_roll_mm`` (default 30 mm) after initial contact, decelerating uniformly to
  rest at foot flat (speed 2 x roll / loading time at contact, 0.7 m/s for the default gait), and the swing
  ends with exactly that velocity.
- Contact type: ``heel_strike_angle_deg`` > 0 lands heel first (toes up, rolling about the heel to foot
  flat), 0 flat-footed, < 0 toe first (heel up, lowering the heel about the toe). Normal gait lands heel
  first at 15-20 degrees (Perry & Burnfield 2010); Parkinsonian gait lands flat-footed with a reduced heel
  load and roll (Kimmeskamp & Hennig 2001, "Heel to toe motion characteristics in Parkinson patients
  during free walking", Clin Biomech 16:806-812), short shuffling steps with little foot clearance
  (Morris et al. 1994, "The pathogenesis of gait hypokinesia in Parkinson's disease", Brain 117:1169-1181);
  the paretic foot after stroke often lands flat or toe first (Perry & Burnfield 2010, ch. 15).
- Leaving (terminal stance, forefoot/toe rocker): the heel rises about 22 % of the stride before toe off
  (``path.HEEL_RISE_FRACTION``) and the foot rolls about the big toe, which is the last point to leave:
  the big-toe keypoint is still at toe off and departs briskly (the swing's speed rises linearly from 0).

References: J. Perry, J. M. Burnfield, Gait Analysis: Normal and Pathological Function, 2nd ed., SLACK
2010. D. A. Winter, "Foot trajectory in human gait: a precise and multifactorial motor control task", Phys
Ther 72:45-53, 1992. C. A. Fukuchi, R. K. Fukuchi, M. Duarte, "A public dataset of overground and
treadmill walking kinematics and kinetics in healthy individuals", PeerJ 6:e4640, 2018.
"""

from __future__ import annotations

import numpy as np


def rolled_back(tau: np.ndarray, roll_mm: float) -> np.ndarray:
    """Distance (mm) the contact point still has to travel at loading progress ``tau`` in [0, 1]
    (uniform deceleration from initial contact to rest at foot flat): ``roll (1 - tau)^2``."""
    tau = np.clip(tau, 0.0, 1.0)
    return roll_mm * (1.0 - tau) ** 2


def landing_speed_mm_s(roll_mm: float, loading_s: float) -> float:
    """Speed (mm/s) of the contact point at initial contact: 2 x roll / loading time."""
    return 2.0 * roll_mm / loading_s if loading_s > 0 else 0.0


def landing_term(tau: np.ndarray) -> np.ndarray:
    """tau^2 (tau - 1): zero at both ends of the swing, zero slope at toe off, slope 1 at contact; the
    swing adds ``landing velocity x swing time x landing_term`` so that it lands at that velocity."""
    tau = np.clip(tau, 0.0, 1.0)
    return tau**2 * (tau - 1.0)
