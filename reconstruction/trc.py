"""TRC (OpenSim / Pose2Sim marker file) export: a pure function returning the file's text."""

from __future__ import annotations

import numpy as np


def to_trc(
    points_mm: np.ndarray, times_s: np.ndarray, joint_names, *, filename: str = "trial.trc", units: str = "mm"
) -> str:
    """Tab-separated TRC text of points (T, J, 3) mm at times (T,) s, one marker per joint.

    Coordinates are written in the world frame of the calibration (z up in gaitcap's synthetic rig) in
    ``units`` ("mm" or "m"). NaN points are written as empty fields (OpenSim reads them as gaps).
    """
    pts = np.asarray(points_mm, dtype=np.float64)
    times = np.asarray(times_s, dtype=np.float64).reshape(-1)
    names = [str(n) for n in joint_names]
    if pts.ndim != 3 or pts.shape[-1] != 3:
        raise ValueError(f"points_mm: expected shape (T, J, 3), got {pts.shape}")
    if pts.shape[0] != times.size:
        raise ValueError(f"times_s: {times.size} times for {pts.shape[0]} frames")
    if pts.shape[1] != len(names):
        raise ValueError(f"joint_names: {len(names)} names for {pts.shape[1]} joints")
    scale = {"mm": 1.0, "m": 1e-3}.get(units)
    if scale is None:
        raise ValueError(f"units: expected 'mm' or 'm', got {units!r}")
    t, j = pts.shape[:2]
    rate = 1.0 / float(np.median(np.diff(times))) if t > 1 else 0.0
    lines = [
        f"PathFileType\t4\t(X/Y/Z)\t{filename}",
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames",
        f"{rate:.2f}\t{rate:.2f}\t{t}\t{j}\t{units}\t{rate:.2f}\t1\t{t}",
        "Frame#\tTime\t" + "\t".join(f"{n}\t\t" for n in names),
        "\t\t" + "\t".join(f"X{i}\tY{i}\tZ{i}" for i in range(1, j + 1)),
        "",
    ]
    for f in range(t):
        vals = ["" if not np.isfinite(v) else f"{v * scale:.5f}" for v in pts[f].reshape(-1)]
        lines.append(f"{f + 1}\t{times[f]:.5f}\t" + "\t".join(vals))
    return "\n".join(lines) + "\n"
