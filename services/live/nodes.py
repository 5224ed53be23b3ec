"""Which bus nodes are alive, and since when (Zenoh liveliness tokens ``<prefix>/alive/<node>``).

Every node (cameras, detector, recorder, workers, the API) holds a liveliness token while it runs; a
process that dies loses it as soon as its connections close (SIGKILL included). :class:`NodeBoard`
follows the tokens and keeps, per node, whether it is alive and since when (UNIX s).
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass


@dataclass(frozen=True)
class NodeState:
    """``alive`` since ``since`` (UNIX s). ``seen_appearing``: the board saw the node come up (it was
    not already there when the board started), so ``since`` is when the process (re)started."""

    name: str
    alive: bool
    since: float
    seen_appearing: bool


class NodeBoard:
    """Follows the nodes' liveliness tokens; :meth:`snapshot` -> {node: NodeState}."""

    def __init__(self, session, bus, *, settle_s: float = 1.0) -> None:
        from gaitcap.services.bus.session import watch_alive

        self._lock = threading.Lock()
        self._nodes: dict[str, NodeState] = {}
        self.started = time.time()
        self._settle_s = settle_s  # tokens reported within this long of the start were already there
        self._sub = watch_alive(session, bus, self._on_change)

    def _on_change(self, node: str, alive: bool) -> None:
        now = time.time()
        with self._lock:
            self._nodes[node] = NodeState(node, alive, now, seen_appearing=now - self.started > self._settle_s)

    def snapshot(self) -> dict[str, NodeState]:
        with self._lock:
            return dict(self._nodes)

    def close(self) -> None:
        self._sub.undeclare()
