"""Writing a C3D file (marker trajectories and gait events) with ezc3d (MIT, pyomeca)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from gaitcap.acquisition.fileio import atomic_path
from gaitcap.reconstruction.kinematics.c3d import C3DContent


def write_c3d(path: Path, content: C3DContent) -> Path:
    """Write ``content`` to ``path`` (temp file + rename): points in mm, z up; gaps as NaN (ezc3d marks
    them invalid); events in the EVENT group (Left/Right, Foot Strike/Foot Off, seconds)."""
    try:
        import ezc3d
    except ImportError as exc:
        raise RuntimeError(f"C3D export needs the 'ezc3d' package ({exc})") from None
    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = [float(content.rate_hz)]
    c["parameters"]["POINT"]["LABELS"]["value"] = list(content.labels)
    c["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    t, j, _ = content.points_mm.shape
    data = np.ones((4, j, t))
    data[:3] = np.transpose(content.points_mm, (2, 1, 0))
    c["data"]["points"] = data
    if content.events:
        for context, label, time in content.events:
            c.add_event(time=[0.0, float(time) - content.first_time_s], context=context, label=label)
    with atomic_path(path) as tmp:
        c.write(str(tmp))
    return Path(path)
