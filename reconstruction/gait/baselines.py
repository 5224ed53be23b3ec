"""Published kinematic gait-event methods, run on the same foot tracks as the default detector (for
comparison only; the report uses ``events.detect_contacts``).

- ``zeni``: Zeni, Richards & Higginson (2008) "Two simple methods for determining gait events during
  treadmill and overground walking using kinematic data", Gait & Posture 27:710-714. Heel strike: maximum
  forward distance of the heel from the pelvis (body centre); toe off: minimum forward distance of the toe
  from the pelvis (the coordinate-based method).
- ``oconnor``: O'Connor, Thorpe, O'Malley & Vaughan (2007) "Automatic detection of gait events using
  kinematic data", Gait & Posture 25:469-474 (foot velocity algorithm). Foot centre = midpoint of heel and
  toe; heel strike: the minimum of its vertical velocity within 0.1 s of the foot centre coming down to
  its stance height (the forefoot's fall after contact); toe off: the maximum of its vertical velocity.
Both work on the continuous trajectory (``FootTracks.sampler``) sampled every ``resolution_s``, with the
forward direction of the whole trial (first to last body-centre position). Peaks closer than
``min_interval_s`` are the same event.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.gait.tracks import CENTER, HEEL, SIDES, TOE, FootTracks
from scipy.signal import find_peaks


@dataclass(frozen=True)
class BaselineConfig:
    """Settings of the baseline methods (s, mm, mm/s)."""

    resolution_s: float = 0.002
    min_interval_s: float = 0.5
    zeni_prominence_mm: float = 100.0
    oconnor_prominence_mm_s: float = 150.0
    oconnor_stance_height_mm: float = 15.0


Events = dict[str, dict[str, np.ndarray]]  # {"heel_strike" | "toe_off": {"left" | "right": (K,) s}}


def _grid(tracks: FootTracks, config: BaselineConfig) -> tuple[np.ndarray, np.ndarray]:
    grid = np.arange(tracks.times_s[0], tracks.times_s[-1], config.resolution_s)
    return grid, tracks.sampler(grid)


def zeni(tracks: FootTracks, config: BaselineConfig = BaselineConfig()) -> Events:
    """Heel strikes and toe offs per foot by Zeni et al. (2008), see the module docstring."""
    grid, pts = _grid(tracks, config)
    travel = pts[-1, CENTER, :2] - pts[0, CENTER, :2]
    fwd = travel / max(np.linalg.norm(travel), 1e-9)
    distance = int(round(config.min_interval_s / config.resolution_s))
    out: Events = {"heel_strike": {}, "toe_off": {}}
    for side in SIDES:
        heel = (pts[:, HEEL[side], :2] - pts[:, CENTER, :2]) @ fwd
        toe = (pts[:, TOE[side], :2] - pts[:, CENTER, :2]) @ fwd
        hs, _ = find_peaks(heel, distance=distance, prominence=config.zeni_prominence_mm)
        to, _ = find_peaks(-toe, distance=distance, prominence=config.zeni_prominence_mm)
        out["heel_strike"][side], out["toe_off"][side] = grid[hs], grid[to]
    return out


def oconnor(tracks: FootTracks, config: BaselineConfig = BaselineConfig()) -> Events:
    """Heel strikes and toe offs per foot by O'Connor et al. (2007), see the module docstring."""
    grid, pts = _grid(tracks, config)
    distance = int(round(config.min_interval_s / config.resolution_s))
    half = int(round(0.1 / config.resolution_s))
    out: Events = {"heel_strike": {}, "toe_off": {}}
    for side in SIDES:
        centre = 0.5 * (pts[:, HEEL[side]] + pts[:, TOE[side]])
        height = centre[:, 2] - np.percentile(centre[:, 2], 5)
        vz = np.gradient(centre[:, 2], grid)
        to, _ = find_peaks(vz, distance=distance, prominence=config.oconnor_prominence_mm_s)
        low = (height < config.oconnor_stance_height_mm).astype(int)
        landings = np.flatnonzero(np.diff(low) == 1) + 1  # the foot centre comes down to stance height
        hs = [a + int(np.argmin(vz[a:b])) for a, b in ((max(k - half, 0), min(k + half, len(grid)))
                                                      for k in landings)]
        out["heel_strike"][side], out["toe_off"][side] = grid[np.asarray(hs, dtype=int)], grid[to]
    return out


BASELINES: dict[str, Callable[[FootTracks, BaselineConfig], Events]] = {"zeni": zeni, "oconnor": oconnor}
