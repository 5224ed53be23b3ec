"""The room frame (z up, mm) and OpenSim's frame (y up): one rotation, used by every export."""

from __future__ import annotations

import numpy as np

# Rows: OpenSim X, Y, Z as combinations of the room's x, y, z. X stays, Y (up) is the room's z, Z is -y, so
# the frame stays right-handed (x cross z = -y).
ROOM_TO_OPENSIM = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def room_to_opensim(points: np.ndarray) -> np.ndarray:
    """Points (..., 3) in the room frame (z up) -> the same points in OpenSim's frame (y up), same units."""
    pts = np.asarray(points, dtype=np.float64)
    if pts.shape[-1] != 3:
        raise ValueError(f"points: expected a last axis of 3 (x, y, z), got shape {pts.shape}")
    return pts @ ROOM_TO_OPENSIM.T


def opensim_to_room(points: np.ndarray) -> np.ndarray:
    """Inverse of :func:`room_to_opensim`."""
    pts = np.asarray(points, dtype=np.float64)
    if pts.shape[-1] != 3:
        raise ValueError(f"points: expected a last axis of 3 (x, y, z), got shape {pts.shape}")
    return pts @ ROOM_TO_OPENSIM
