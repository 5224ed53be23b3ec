"""Settings of the gait analysis (one frozen dataclass, every threshold in named units)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class GaitConfig:
    """Thresholds of bout, event and parameter detection.

    Attributes:
        min_trial_s: shortest trial analysed (s).
        max_fill_gap_s: NaN gaps up to this long are interpolated; longer gaps are excluded (s).
        smoothing_window_s: Savitzky-Golay window (cubic) applied to the frames before the spline when no
            continuous trajectory is given (s; 0 disables; None: automatic, ``auto_smoothing_window_s``
            when the feet's noise at rest exceeds ``auto_smoothing_noise_mm_s``, else none).
        auto_smoothing_window_s, auto_smoothing_noise_mm_s: see smoothing_window_s.
        bout_smoothing_s: moving-average window on the body centre for speed and heading (s).
        min_walking_speed_mm_s: body-centre speed above which a person is walking (mm/s).
        max_turn_rate_deg_s: heading rate above which walking counts as turning (deg/s).
        max_heading_deviation_deg: largest heading deviation from a pass's median heading (deg).
        min_pass_s: shortest straight walking segment kept as a pass (s).
        steady_speed_fraction: a pass's ends slower than this fraction of its median speed (starting,
            stopping) are not part of it.
        rest_speed_fraction: foot point at rest when slower than this fraction of the walking speed,
            or than ``rest_noise_factor`` x the feet's noise at rest if that is higher.
        rest_noise_factor: see rest_speed_fraction.
        min_rest_speed_mm_s: lower bound of that rest-speed threshold (mm/s).
        min_event_speed_mm_s: events are located where the foot's speed crosses this (mm/s), or
            ``event_noise_factor`` x the median speed at rest when the trajectory is noisier, at most the
            rest threshold: the lower, the smaller the early/late bias of the events.
        event_noise_factor: see min_event_speed_mm_s.
        extrapolate_events: extrapolate each event from its speed crossings to zero speed (see events);
            None: only when a continuous trajectory is given (a spline through 30 fps frames rings near
            the abrupt stop of a heel, which defeats the extrapolation).
        max_contact_lift_mm: a foot is on the ground only if heel or toe is within this height of its
            stance height (mm).
        min_stance_s: shortest foot contact kept (s).
        min_swing_s: shorter swings are treated as a noise blip inside one contact (s).
        min_foot_travel_mm: consecutive contacts of a foot closer than this are one contact (mm).
        contact_walking_s: heel strike is the first time heel or toe comes within the distance walked in
            this time (s, at the trial's walking speed; 30 mm at 1.2 m/s) of where it rests in stance, at
            least ``contact_distance_mm``. Real heels land moving and roll to rest (heel rocker); a heel
            arrives, and rolls, slower in a slower gait (see events).
        contact_distance_mm: the least such distance (mm; above the rest point's noise and a fit's rounding
            of the heel's stop; 0: speed thresholds only, for both events).
        toe_off_distance_mm: toe off is the last time the toe is within this distance of where it rested
            (mm); the toe off is then refined to the toe's farthest point behind the body centre within
            ``toe_off_window_s`` of that (Zeni et al. 2008).
        toe_off_window_s: see toe_off_distance_mm (s).
        heel_landing_window_s: a heel-first landing's heel strike is the heel's lowest point within this
            long after the contact-distance crossing (s; 0: the crossing only; see events).
        heel_landing_dip_mm: the landing is heel first when the heel, at that lowest point, is at least this
            far below its stance height (mm: a heel point behind the heel's floor contact dips as the
            pitched-up foot lands on it), and ``heel_landing_noise_factor`` x the noise of its height over
            that contact's frames (mm, from their second differences: a dip within the noise is no
            landing) ...
        heel_landing_noise_factor: see heel_landing_dip_mm.
        heel_landing_pitch_deg: ... and the foot is pitched toe up by at least this much more than in
            stance (degrees) ...
        heel_landing_lever_mm: ... and by enough to explain the dip: a heel point at most this far behind
            the heel's floor contact (mm) dips at most this x the sine of the pitch.
        event_resolution_s: resolution of sub-frame event location on the continuous trajectory (s).
        full_confidence_views: cameras needed at a contact for full confidence (with quality given).
        reprojection_scale_px: reprojection error that lowers confidence by a factor e (px).
        stance_spread_scale_mm: spread of the heel during stance that lowers confidence by e (mm).
        low_confidence: steps whose confidence is below this are flagged (``Step.low_confidence``).
    """

    min_trial_s: float = 2.0
    max_fill_gap_s: float = 0.25
    smoothing_window_s: float | None = None
    auto_smoothing_window_s: float = 0.3
    auto_smoothing_noise_mm_s: float = 40.0
    bout_smoothing_s: float = 1.0
    min_walking_speed_mm_s: float = 150.0
    max_turn_rate_deg_s: float = 35.0
    max_heading_deviation_deg: float = 25.0
    min_pass_s: float = 1.5
    steady_speed_fraction: float = 0.8
    rest_speed_fraction: float = 0.08
    rest_noise_factor: float = 2.0
    min_rest_speed_mm_s: float = 40.0
    min_event_speed_mm_s: float = 10.0
    event_noise_factor: float = 3.0
    extrapolate_events: bool | None = None
    toe_off_peak_fraction: float = 0.1
    event_window_s: float = 0.4
    max_contact_lift_mm: float = 80.0
    min_stance_s: float = 0.12
    min_swing_s: float = 0.12
    min_foot_travel_mm: float = 100.0
    contact_walking_s: float = 0.025
    contact_distance_mm: float = 20.0
    toe_off_distance_mm: float = 30.0
    toe_off_window_s: float = 0.1
    heel_landing_window_s: float = 0.15
    heel_landing_dip_mm: float = 3.0
    heel_landing_noise_factor: float = 3.0
    heel_landing_pitch_deg: float = 6.0
    heel_landing_lever_mm: float = 60.0
    event_resolution_s: float = 0.001
    full_confidence_views: int = 3
    reprojection_scale_px: float = 10.0
    stance_spread_scale_mm: float = 20.0
    low_confidence: float = 0.3

    def __post_init__(self) -> None:
        for name, value in self.__dict__.items():
            if value is not None and not value >= 0:
                raise ValueError(f"GaitConfig.{name} must be >= 0, got {value}")
