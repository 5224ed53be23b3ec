"""A TRC reference (marker trajectories only: no events, no angles)."""

from __future__ import annotations

from pathlib import Path

from gaitcap.reconstruction.trc import parse_trc
from gaitcap.reconstruction.validation.reference import Reference, map_markers


def read_trc(path: Path) -> Reference:
    source = str(path)
    times, markers = parse_trc(Path(path).read_text(encoding="utf-8"), source=source)
    joints, used = map_markers(markers)
    if not joints:
        raise ValueError(f"{source}: no heel, ankle, knee, hip or toe markers (e.g. LHEE or left_heel)")
    return Reference(source, "TRC", times, joints, used,
                     lacks=("gait events (a TRC holds markers only)", "joint angles (a TRC holds markers only)"))
