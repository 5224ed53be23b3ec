"""Parameters of the synthetic walker: one frozen dataclass, validated, with a few named gait patterns.

All lengths in mm, angles in degrees, times in s. Step length, step width and cadence are the primary
spatiotemporal parameters; walking speed follows from them (``speed_mm_s``).
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass

SIDES = ("left", "right")


@dataclass(frozen=True)
class WalkParams:
    """How the synthetic patient walks (and how the body is built).

    Gait (straight passes reproduce these exactly, see :mod:`gaitcap.simulator.truth`):
        step_length_mm: mean step length (heel to previous contralateral heel, along progression).
        step_width_mm: heel-to-heel lateral distance (base of support).
        cadence_spm: steps per minute (both feet together).
        stance_fraction: stance time / stride time of a symmetric gait (normal about 0.60-0.62).
        step_asymmetry: the ``short_side`` steps are ``(1 - a)`` times the mean, the other side's
            ``(1 + a)``; stride length stays ``2 * step_length_mm``.
        stance_asymmetry: the ``short_side`` stance fraction is ``stance_fraction + s``, the other's
            ``stance_fraction - s`` (a hemiparetic gait: shorter step, longer stance on the sound side).
        short_side: "left" or "right".
        lead_foot: the foot that takes the first step.
    Body (one body per trial, rigid limbs):
        height_mm: standing height; the segment lengths default to anthropometric ratios of it.
        thigh_mm, shank_mm, upper_arm_mm, forearm_mm, foot_mm, hip_width_mm, shoulder_width_mm:
            overrides (None = from height). ``foot_mm`` is the heel-to-big-toe keypoint distance.
    Style:
        arm_swing_deg: peak shoulder flexion/extension of the arm swing.
        heel_strike_angle_deg: foot-floor angle at initial contact: > 0 heel first (toes up), 0 flat foot,
            < 0 toe first (heel up); see :mod:`gaitcap.simulator.foot`.
        paretic_heel_strike_angle_deg: the same for the side that is not ``short_side`` (the paretic side
            of ``hemiparetic``), None: ``heel_strike_angle_deg``.
        heel_roll_mm: distance the foot's contact point still travels after initial contact, rolling to
            rest at foot flat (real heels: 20-40 mm).
        toe_off_angle_deg: foot-floor angle (heel up) at toe-off.
        swing_lift_mm: extra heel lift in the swing, highest a quarter into it (real heels keep rising after
            toe off; with 70 mm the walker's toes rise to about 100 mm, as in the healthy walk of ``mocap.py``).
        pelvis_sway_mm: lateral pelvis shift towards the stance foot.
        pelvis_rotation_deg: transverse pelvis rotation (trunk counter-rotates).
        trunk_lean_deg: forward trunk lean while walking.
    Path (the paper's room, walking its diagonal there and back):
        turn_steps: steps taken to turn 180 degrees at each end.
        turn_radius_mm: radius of the turn (passes run this far either side of the diagonal).
        walkway_margin_mm: distance from the room corners (along the diagonal) where the passes end.
        stand_start_s, stand_end_s: minimum standing time before the first and after the last step.
    Variability (0 = every straight step exactly as requested; > 0: step-to-step random variation drawn
    from the trial's seed, the ground truth then follows the realised footprints):
        step_length_sd_mm, step_width_sd_mm: sd of each footprint's forward / lateral placement.
        step_time_sd_s: sd of each step's duration.
    """

    step_length_mm: float = 650.0
    step_width_mm: float = 100.0
    cadence_spm: float = 110.0
    stance_fraction: float = 0.62
    step_asymmetry: float = 0.0
    stance_asymmetry: float = 0.0
    short_side: str = "left"
    lead_foot: str = "right"
    height_mm: float = 1750.0
    thigh_mm: float | None = None
    shank_mm: float | None = None
    upper_arm_mm: float | None = None
    forearm_mm: float | None = None
    foot_mm: float | None = None
    hip_width_mm: float | None = None
    shoulder_width_mm: float | None = None
    arm_swing_deg: float = 18.0
    heel_strike_angle_deg: float = 18.0
    paretic_heel_strike_angle_deg: float | None = None
    heel_roll_mm: float = 30.0
    toe_off_angle_deg: float = 45.0
    swing_lift_mm: float = 70.0
    pelvis_sway_mm: float = 22.0
    pelvis_rotation_deg: float = 4.0
    trunk_lean_deg: float = 3.0
    turn_steps: int = 4
    turn_radius_mm: float = 250.0
    walkway_margin_mm: float = 1400.0
    stand_start_s: float = 1.0
    stand_end_s: float = 1.0
    step_length_sd_mm: float = 0.0
    step_width_sd_mm: float = 0.0
    step_time_sd_s: float = 0.0

    def __post_init__(self) -> None:
        def need(cond: bool, msg: str) -> None:
            if not cond:
                raise ValueError(f"WalkParams: {msg}")

        need(200.0 <= self.step_length_mm <= 1200.0, f"step_length_mm must be in [200, 1200], got {self.step_length_mm}")
        need(0.0 <= self.step_width_mm <= 400.0, f"step_width_mm must be in [0, 400], got {self.step_width_mm}")
        need(40.0 <= self.cadence_spm <= 180.0, f"cadence_spm must be in [40, 180], got {self.cadence_spm}")
        need(0.52 <= self.stance_fraction <= 0.75, f"stance_fraction must be in [0.52, 0.75], got {self.stance_fraction}")
        need(0.0 <= self.step_asymmetry <= 0.4, f"step_asymmetry must be in [0, 0.4], got {self.step_asymmetry}")
        need(
            0.0 <= self.stance_asymmetry <= 0.08 and self.stance_fraction - self.stance_asymmetry > 0.51,
            f"stance_asymmetry must be in [0, 0.08] and leave both stance fractions > 0.51, got {self.stance_asymmetry}",
        )
        need(self.short_side in SIDES, f"short_side must be 'left' or 'right', got {self.short_side!r}")
        need(self.lead_foot in SIDES, f"lead_foot must be 'left' or 'right', got {self.lead_foot!r}")
        need(1200.0 <= self.height_mm <= 2200.0, f"height_mm must be in [1200, 2200], got {self.height_mm}")
        for name in ("thigh_mm", "shank_mm", "upper_arm_mm", "forearm_mm", "foot_mm", "hip_width_mm", "shoulder_width_mm"):
            v = getattr(self, name)
            need(v is None or 50.0 <= v <= 800.0, f"{name} must be None or in [50, 800], got {v}")
        need(0.0 <= self.arm_swing_deg <= 60.0, f"arm_swing_deg must be in [0, 60], got {self.arm_swing_deg}")
        for name in ("heel_strike_angle_deg", "paretic_heel_strike_angle_deg"):
            v = getattr(self, name)
            need(v is None or -20.0 <= v <= 35.0, f"{name} must be in [-20, 35], got {v}")
        need(0.0 <= self.heel_roll_mm <= 60.0, f"heel_roll_mm must be in [0, 60], got {self.heel_roll_mm}")
        need(5.0 <= self.toe_off_angle_deg <= 70.0, "toe_off_angle_deg must be in [5, 70]")
        need(0.0 <= self.swing_lift_mm <= 200.0, "swing_lift_mm must be in [0, 200]")
        need(0.0 <= self.pelvis_sway_mm <= 80.0, "pelvis_sway_mm must be in [0, 80]")
        need(0.0 <= self.pelvis_rotation_deg <= 15.0, "pelvis_rotation_deg must be in [0, 15]")
        need(-10.0 <= self.trunk_lean_deg <= 20.0, "trunk_lean_deg must be in [-10, 20]")
        need(2 <= int(self.turn_steps) <= 12, f"turn_steps must be in [2, 12], got {self.turn_steps}")
        need(100.0 <= self.turn_radius_mm <= 1000.0, "turn_radius_mm must be in [100, 1000]")
        need(500.0 <= self.walkway_margin_mm <= 3000.0, "walkway_margin_mm must be in [500, 3000]")
        need(0.0 <= self.step_length_sd_mm <= 60.0, "step_length_sd_mm must be in [0, 60]")
        need(0.0 <= self.step_width_sd_mm <= 40.0, "step_width_sd_mm must be in [0, 40]")
        need(0.0 <= self.step_time_sd_s <= 0.04, "step_time_sd_s must be in [0, 0.04]")
        need(0.0 <= self.stand_start_s <= 60.0 and 0.0 <= self.stand_end_s <= 60.0, "standing times must be in [0, 60] s")

    # -- derived quantities ------------------------------------------------------------------------
    @property
    def speed_mm_s(self) -> float:
        """Mean walking speed on straight passes (mm/s)."""
        return self.step_length_mm * self.cadence_spm / 60.0

    @property
    def stride_time_s(self) -> float:
        return 120.0 / self.cadence_spm

    def side_step_length_mm(self, side: str) -> float:
        """Step length of the steps taken with ``side`` (the foot that lands)."""
        a = self.step_asymmetry
        return self.step_length_mm * ((1 - a) if side == self.short_side else (1 + a))

    def side_heel_strike_angle_deg(self, side: str) -> float:
        """Foot-floor angle at initial contact of ``side`` (degrees; < 0 toe first)."""
        if side != self.short_side and self.paretic_heel_strike_angle_deg is not None:
            return self.paretic_heel_strike_angle_deg
        return self.heel_strike_angle_deg

    def side_stance_fraction(self, side: str) -> float:
        s = self.stance_asymmetry
        return self.stance_fraction + (s if side == self.short_side else -s)

    def to_json(self) -> str:
        return json.dumps(dataclasses.asdict(self), sort_keys=True)

    @classmethod
    def from_json(cls, text: str) -> WalkParams:
        data = json.loads(text)
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"WalkParams: unknown fields {unknown}")
        return cls(**data)

    def replace(self, **changes) -> WalkParams:
        return dataclasses.replace(self, **changes)

    # -- named patterns ---------------------------------------------------------------------------
    @classmethod
    def hemiparetic(cls, paretic_side: str = "left", **changes) -> WalkParams:
        """A slow asymmetric gait: the sound side takes shorter steps and stands longer; the paretic foot
        lands toe first (-5 degrees) and rolls less."""
        if paretic_side not in SIDES:
            raise ValueError(f"paretic_side must be 'left' or 'right', got {paretic_side!r}")
        sound = "right" if paretic_side == "left" else "left"
        base = dict(
            step_length_mm=480.0, step_width_mm=160.0, cadence_spm=88.0, stance_fraction=0.66,
            step_asymmetry=0.15, stance_asymmetry=0.05, short_side=sound, arm_swing_deg=8.0,
            toe_off_angle_deg=30.0, heel_strike_angle_deg=8.0, paretic_heel_strike_angle_deg=-5.0,
            heel_roll_mm=20.0, turn_steps=6,
        )
        base.update(changes)
        return cls(**base)

    @classmethod
    def parkinsonian(cls, **changes) -> WalkParams:
        """Shuffling: short quick steps, flat-foot contacts with little roll, low clearance, little arm
        swing (see :mod:`gaitcap.simulator.foot`)."""
        base = dict(step_length_mm=420.0, step_width_mm=120.0, cadence_spm=112.0, stance_fraction=0.66,
                    arm_swing_deg=5.0, heel_strike_angle_deg=0.0, heel_roll_mm=15.0, toe_off_angle_deg=25.0,
                    swing_lift_mm=5.0, trunk_lean_deg=10.0, turn_steps=8)
        base.update(changes)
        return cls(**base)

    @classmethod
    def slow(cls, **changes) -> WalkParams:
        """An elderly / cautious gait."""
        base = dict(step_length_mm=520.0, step_width_mm=130.0, cadence_spm=96.0, stance_fraction=0.65, arm_swing_deg=10.0,
                    heel_strike_angle_deg=12.0, heel_roll_mm=25.0)
        base.update(changes)
        return cls(**base)
