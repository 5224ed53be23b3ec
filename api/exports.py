"""Turning stored results into download formats (CSV text, trajectory JSON/CSV)."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np


def steps_csv(steps: list[dict], warnings: list[str] = (), *, void_reason: str | None = None) -> str:
    """One row per step; columns = the union of the steps' keys (first-seen order). A void trial's file
    starts with ``# VOID - not for clinical use: <reason>``; the trial's data-quality ``warnings`` follow,
    one ``# warning: ...`` line each (read with ``comment="#"``)."""
    columns: list[str] = []
    for step in steps:
        columns += [k for k in step if k not in columns]
    out = io.StringIO()
    if void_reason is not None:
        out.write("# VOID - not for clinical use: " + " ".join(void_reason.split()) + "\n")
    out.writelines(f"# warning: {w}\n" for w in warnings)
    writer = csv.DictWriter(out, fieldnames=columns or ["side"], extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    writer.writerows(steps)
    return out.getvalue()


def load_trajectory(path: Path) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(points_mm (T, J, 3), times_s (T,), joint_names) from the worker's trajectory .npz."""
    with np.load(path, allow_pickle=False) as z:
        return np.asarray(z["points_mm"]), np.asarray(z["times_s"]), [str(n) for n in z["joint_names"]]


def trajectory_json(path: Path) -> dict:
    points, times, names = load_trajectory(path)
    rounded = np.round(points, 2)
    return {
        "units": {"points": "mm", "times": "s"},
        "joint_names": names,
        "times_s": np.round(times, 5).tolist(),
        "points_mm": [[[None if not np.isfinite(v) else float(v) for v in p] for p in frame] for frame in rounded],
    }


def trajectory_csv(path: Path) -> str:
    points, times, names = load_trajectory(path)
    header = ["time_s"] + [f"{n}_{a}_mm" for n in names for a in "xyz"]
    flat = np.concatenate([times[:, None], points.reshape(len(times), -1)], axis=1)
    out = io.StringIO()
    out.write(",".join(header) + "\n")
    np.savetxt(out, flat, delimiter=",", fmt="%.3f")
    return out.getvalue()
