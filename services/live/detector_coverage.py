"""Live detection coverage, as ``/status`` reports it: from the detector nodes' status messages
(:class:`gaitcap.services.bus.messages.DetectorStatus` on ``<prefix>/detector/status/<node>``).

:func:`detection_summary` -> ``{"nodes": {node: {workers, pool, age_s, stale}}, "cameras": {camera: {node,
received, detected, skipped, lost, failed, coverage, lag_s}}}``: ``coverage`` is detected / received (0..1,
None before a frame), ``lag_s`` the lag (s) of the camera's latest detected frame. A node silent for
``STALE_S`` is ``stale`` (its process died or hangs); its cameras keep their last counts.
"""

from __future__ import annotations

import threading
import time

from gaitcap.services.bus.control import named_by_key
from gaitcap.services.bus.messages import DetectorStatus

STALE_S = 5.0


def detection_summary(latest: dict[str, tuple[float, DetectorStatus]], now_s: float) -> dict:
    """The summary of ``latest`` ({node: (received at, UNIX s; its newest status)}) at ``now_s``."""
    nodes, cameras = {}, {}
    for node, (seen_s, status) in sorted(latest.items()):
        age = max(0.0, now_s - seen_s)
        nodes[node] = {"workers": status.workers, "pool": status.pool, "age_s": round(age, 2), "stale": age > STALE_S}
        for cam, row in status.cameras.items():
            if cam in cameras and cameras[cam]["received"] >= row["received"]:
                continue  # a camera moved between nodes: the node that saw more of it
            cov = row["detected"] / row["received"] if row["received"] else None
            cameras[cam] = {"node": node, **row, "coverage": None if cov is None else round(min(cov, 1.0), 4)}
    return {"nodes": nodes, "cameras": dict(sorted(cameras.items()))}


class DetectorCoverageBoard:
    """Keeps every detector node's newest status; :meth:`snapshot` -> :func:`detection_summary`."""

    def __init__(self, session, keys) -> None:
        self._lock = threading.Lock()
        self._latest: dict[str, tuple[float, DetectorStatus]] = {}
        self._sub = session.declare_subscriber(
            keys.detector_status(), named_by_key(DetectorStatus, self._keep, field="node", name_of=keys.node_of))

    def _keep(self, status: DetectorStatus) -> None:
        with self._lock:
            self._latest[status.node] = (time.time(), status)

    def snapshot(self) -> dict:
        with self._lock:
            latest = dict(self._latest)
        return detection_summary(latest, time.time())

    def close(self) -> None:
        self._sub.undeclare()
