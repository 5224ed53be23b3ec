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
    {"heel_strike_s": [...], "toe_off_s": [...]}}}``; a missing heel joint gives an empty trace.
    FileNotFoundError when the trajectory file is missing."""
    if not Path(npz_path).is_file():
        raise FileNotFoundError(f"{Path(npz_path).name}: the trajectory of this stage is missing")
    with np.load(npz_path) as data:
        points, times, names = data["points_mm"], data["times_s"], [str(n) for n in data["joint_names"]]
    step = max(1, math.ceil(len(times) / max_samples))
    out: dict = {"times_s": [round(float(t), 3) for t in times[::step]]}
    for side in SIDES:
        name = f"{side}_heel"
        out[f"{side}_heel_z_mm"] = _clean(points[::step, names.index(name), 2]) if name in names else []
    contacts = (gait or {}).get("contacts") or []
    out["events"] = {side: {key: [round(c[key], 3) for c in contacts if c.get("foot") == side
                                  and isinstance(c.get(key), (int, float)) and math.isfinite(c[key])]
                            for key in ("heel_strike_s", "toe_off_s")} for side in SIDES}
    return out
