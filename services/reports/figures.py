"""Data of the page's interactive figures, from a stage's stored files: both heels' height over time
(mm, s; at most ``max_samples`` samples) with each foot's heel strikes and toe offs (s) from the gait
analysis's contacts."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

SIDES = ("left", "right")


def _clean(values: np.ndarray) -> list[float | None]:
    return [round(float(v), 1) if math.isfinite(v) else None for v in values]


def heel_traces(npz_path: Path, gait: dict | None, *, max_samples: int = 1500) -> dict:
    """``{"times_s": [...], "left_heel_z_mm": [...], "right_heel_z_mm": [...], "events": {side:
    {"heel_strike_s": [...], "toe_off_s": [...]}}, "implausible": {side: frames}}``; a missing heel joint
    gives an empty trace. A frame whose heel no walking heel can be (below the floor, too high, or a point
    that not even two views agree on: :func:`~gaitcap.reconstruction.gait.plausibility.implausible_heel_frames`)
    is left out of the trace (None) and counted in ``implausible``, never drawn.
    FileNotFoundError when the trajectory file is missing."""
    from gaitcap.reconstruction.gait.plausibility import implausible_heel_frames

    if not Path(npz_path).is_file():
        raise FileNotFoundError(f"{Path(npz_path).name}: the trajectory of this stage is missing")
    with np.load(npz_path) as data:
        points, times, names = data["points_mm"], data["times_s"], [str(n) for n in data["joint_names"]]
        views = data["num_views"] if "num_views" in data.files and data["num_views"].shape == points.shape[:2] else None
    step = max(1, math.ceil(len(times) / max_samples))
    out: dict = {"times_s": [round(float(t), 3) for t in times[::step]], "implausible": {}}
    for side in SIDES:
        name = f"{side}_heel"
        if name not in names:
            out[f"{side}_heel_z_mm"] = []
            continue
        j = names.index(name)
        z = np.asarray(points[:, j, 2], dtype=np.float64)
        bad = implausible_heel_frames(z, None if views is None else views[:, j])
        out[f"{side}_heel_z_mm"] = _clean(np.where(bad, np.nan, z)[::step])
        out["implausible"][side] = int(bad.sum())
    contacts = (gait or {}).get("contacts") or []
    out["events"] = {side: {key: [round(c[key], 3) for c in contacts if c.get("foot") == side
                                  and isinstance(c.get(key), (int, float)) and math.isfinite(c[key])]
                            for key in ("heel_strike_s", "toe_off_s")} for side in SIDES}
    return out
