"""TRC (OpenSim / Pose2Sim marker file) export: a pure function returning the file's text."""

from __future__ import annotations

import numpy as np
from gaitcap.reconstruction.kinematics.frames import room_to_opensim

UNIT_SCALES = {"mm": 1.0, "m": 1e-3}


def to_trc(
    points_mm: np.ndarray, times_s: np.ndarray, joint_names, *, filename: str = "trial.trc", units: str = "mm"
) -> str:
    """Tab-separated TRC text of points (T, J, 3) mm in the room frame at times (T,) s, one marker per name.

    Written in OpenSim's convention: y up (X = room x, Y = room z, Z = -room y), in ``units`` ("mm" or "m",
    named in the header's Units column, which OpenSim reads). Missing points are written as ``NaN``, which
    OpenSim reads as gaps (empty fields at the end of a row make its reader miscount the columns).
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
    scale = UNIT_SCALES.get(units)
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
    values = room_to_opensim(pts) * scale
    for f in range(t):
        vals = ["NaN" if not np.isfinite(v) else f"{v:.6f}" for v in values[f].reshape(-1)]
        lines.append(f"{f + 1}\t{times[f]:.6f}\t" + "\t".join(vals))
    return "\n".join(lines) + "\n"


def parse_trc(text: str, *, source: str = "<trc>") -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(times (T,) s, marker name -> (T, 3) mm) of a TRC file's text, in the file's own axes, scaled from
    the header's Units (mm or m); empty fields are NaN. Errors name ``source``."""
    lines = text.splitlines()
    if len(lines) < 6:
        raise ValueError(f"{source}: not a TRC file (fewer than 6 lines)")
    header = dict(zip(lines[1].split("\t"), lines[2].split("\t"), strict=False))
    scale = UNIT_SCALES.get(header.get("Units", "mm").strip())
    if scale is None:
        raise ValueError(f"{source}: Units {header.get('Units')!r} is neither mm nor m")
    names = [n for n in lines[3].split("\t")[2:] if n.strip()]
    rows = [r.split("\t") for r in lines[5:] if r.strip()]
    if not rows:
        raise ValueError(f"{source}: TRC file has no frames")

    def num(cell: str) -> float:
        try:
            return float(cell) if cell.strip() else float("nan")
        except ValueError:
            raise ValueError(f"{source}: {cell!r} is not a number") from None

    data = np.array([[num(c) for c in (r + [""] * (2 + 3 * len(names) - len(r)))[: 2 + 3 * len(names)]]
                     for r in rows])
    times = data[:, 1]
    markers = {n: data[:, 2 + 3 * k: 5 + 3 * k] / scale for k, n in enumerate(names)}
    return times - times[0], markers
