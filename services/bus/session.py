"""Zenoh sessions for gaitcap nodes: peer mode, explicit endpoints, no scouting; liveliness tokens.

The bus is a mesh of peers with EXPLICIT endpoints (no multicast or gossip scouting, so nothing is
discovered or announced beyond the listed addresses). A :class:`BusConfig` names every long-running
node and the endpoint it listens on; a node listens on its own endpoint and connects to all the others
(Zenoh retries endpoints that are not up yet, so start order does not matter). Short-lived clients
(CLI commands, the web service's recorder client, tests) listen nowhere and connect to every node.

Default (one host): nodes on ``tcp/127.0.0.1:7447`` and up (:func:`BusConfig.local`). Several hosts:
a JSON5/JSON bus file (``deploy/zenoh/*.json5``)::

    {
      prefix: "gaitcap/lab1",                 // key prefix of this rig
      lease_ms: 3000,                         // a hung node is declared gone after this long
      nodes: {                                // node name -> the endpoint it listens on
        "camera-0": "tcp/192.168.50.10:7447", // acquisition PC
        "recorder": "tcp/192.168.50.20:7447", // processing PC
      },
    }

Use ``--bus FILE`` on the node commands, or set ``GAITCAP_BUS=FILE`` for every process.

Security: a bus whose endpoints reach beyond loopback needs a ``security`` section (mutual TLS on
``tls/`` endpoints, user/password, access control by node role: :mod:`gaitcap.services.bus.security`;
keys from ``gaitcap bus-keys``), or ``insecure_plain: true`` to say explicitly that the network is
trusted. A loopback-only bus may stay plain; every node says so in its log at start-up.
"""

from __future__ import annotations

import json
import logging
import os
import random
import re
import socket
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gaitcap.services.bus.keys import DEFAULT_PREFIX, Keys, check_name
from gaitcap.services.bus.security import BusSecurity, zenoh_security

log = logging.getLogger(__name__)

BUS_ENV = "GAITCAP_BUS"
DEFAULT_BASE_PORT = 7447
LOCAL_NODES = ("recorder", "detector", "worker", "api", "replay", *(f"camera-{i}" for i in range(10)))
_ENDPOINT = re.compile(r"^(tcp|udp|tls|quic)/[^\s:]+:\d{1,5}$|^(tcp|udp|tls|quic)/\[[0-9a-fA-F:]+\]:\d{1,5}$")
_LOOPBACK_HOSTS = ("127.0.0.1", "localhost", "[::1]")


def _host(endpoint: str) -> str:
    return endpoint.split("/", 1)[1].rsplit(":", 1)[0]


@dataclass(frozen=True)
class BusConfig:
    """The rig's bus: key prefix, node endpoints and liveliness lease.

    Attributes:
        nodes: node name -> the endpoint it listens on (``tcp/host:port``).
        prefix: key-expression prefix of this rig.
        lease_ms: a node that stops answering (hung, unplugged) is declared gone after this long.
        security: mTLS + user/password + access control (None: plain TCP).
        insecure_plain: explicitly allow a plain bus beyond loopback (a trusted, isolated network).
    """

    nodes: dict[str, str] = field(default_factory=dict)
    prefix: str = DEFAULT_PREFIX
    lease_ms: int = 3000
    security: BusSecurity | None = None
    insecure_plain: bool = False

    def __post_init__(self) -> None:
        for name, endpoint in self.nodes.items():
            check_name(name, what="bus node")
            if not isinstance(endpoint, str) or not _ENDPOINT.match(endpoint):
                raise ValueError(f"bus node {name}: endpoint {endpoint!r} is not like 'tcp/127.0.0.1:7447'")
        dup = {e for e in self.nodes.values() if list(self.nodes.values()).count(e) > 1}
        if dup:
            raise ValueError(f"bus nodes: endpoints used twice {sorted(dup)}")
        if self.lease_ms < 500:
            raise ValueError(f"lease_ms: must be >= 500, got {self.lease_ms}")
        Keys(self.prefix)
        if self.security is not None:
            plain = sorted(n for n, e in self.nodes.items() if not e.startswith("tls/"))
            if plain:
                raise ValueError(f"security: nodes {plain} must listen on tls/ endpoints")
        elif not self.loopback_only and not self.insecure_plain:
            raise ValueError("the bus listens beyond loopback without security: add a 'security' section "
                             "(keys from 'gaitcap bus-keys') or, on a trusted isolated network, insecure_plain: true")

    @property
    def loopback_only(self) -> bool:
        return all(_host(e) in _LOOPBACK_HOSTS for e in self.nodes.values())

    @property
    def identities(self) -> list[str]:
        """Every name that may join the bus: the nodes and the security section's clients."""
        extra = self.security.clients if self.security is not None else ()
        return [*self.nodes, *(c for c in extra if c not in self.nodes)]

    @property
    def keys(self) -> Keys:
        return Keys(self.prefix)

    @classmethod
    def local(cls, base_port: int = DEFAULT_BASE_PORT, *, prefix: str = DEFAULT_PREFIX,
              nodes: tuple[str, ...] = LOCAL_NODES) -> BusConfig:
        """All nodes on 127.0.0.1, ports ``base_port``, ``base_port + 1``, ... in ``nodes`` order."""
        return cls({n: f"tcp/127.0.0.1:{base_port + i}" for i, n in enumerate(nodes)}, prefix=prefix)

    @classmethod
    def free_local(cls, nodes, *, prefix: str = DEFAULT_PREFIX) -> BusConfig:
        """All ``nodes`` on 127.0.0.1 at ports the OS reports free now (tests, throw-away stacks)."""
        nodes = tuple(nodes)
        ports = free_loopback_ports(len(nodes))
        return cls({n: f"tcp/127.0.0.1:{p}" for n, p in zip(nodes, ports, strict=True)}, prefix=prefix)

    def listen_for(self, node: str | None) -> list[str]:
        return [self.nodes[node]] if node in self.nodes else []

    def connect_for(self, node: str | None) -> list[str]:
        return [e for n, e in self.nodes.items() if n != node]

    def to_dict(self) -> dict[str, Any]:
        out = {"prefix": self.prefix, "lease_ms": self.lease_ms, "nodes": dict(self.nodes)}
        if self.security is not None:
            out["security"] = self.security.to_dict()
        if self.insecure_plain:
            out["insecure_plain"] = True
        return out


def _strip_json5(text: str) -> str:
    """JSON5 subset -> JSON: // and /* */ comments, trailing commas, unquoted keys."""
    out, i, n = [], 0, len(text)
    while i < n:
        ch = text[i]
        if ch in "\"'":
            j = i + 1
            while j < n and text[j] != ch:
                j += 2 if text[j] == "\\" else 1
            out.append('"' + text[i + 1 : j].replace('"', '\\"') + '"' if ch == "'" else text[i : j + 1])
            i = j + 1
        elif text.startswith("//", i):
            i = text.find("\n", i) if "\n" in text[i:] else n
        elif text.startswith("/*", i):
            end = text.find("*/", i + 2)
            i = n if end < 0 else end + 2
        else:
            out.append(ch)
            i += 1
    s = "".join(out)
    s = re.sub(r",(\s*[}\]])", r"\1", s)
    return re.sub(r"([{,]\s*)([A-Za-z_][A-Za-z0-9_]*)(\s*:)", r'\1"\2"\3', s)


def load_bus_config(path: str | os.PathLike) -> BusConfig:
    """Read a JSON5/JSON bus file (see the module docstring); ValueError naming the bad field."""
    p = Path(path)
    try:
        data = json.loads(_strip_json5(p.read_text()))
    except json.JSONDecodeError as exc:
        raise ValueError(f"bus file {p}: not valid JSON5 ({exc})") from None
    if not isinstance(data, dict) or not isinstance(data.get("nodes"), dict):
        raise ValueError(f"bus file {p}: expected an object with a 'nodes' object (name -> endpoint)")
    unknown = sorted(set(data) - {"prefix", "lease_ms", "nodes", "security", "insecure_plain"})
    if unknown:
        raise ValueError(f"bus file {p}: unknown fields {unknown}")
    try:
        security = BusSecurity.from_dict(data["security"], base=p.parent) if "security" in data else None
        return BusConfig(nodes=data["nodes"], prefix=data.get("prefix", DEFAULT_PREFIX),
                         lease_ms=int(data.get("lease_ms", 3000)), security=security,
                         insecure_plain=data.get("insecure_plain") is True)
    except ValueError as exc:
        raise ValueError(f"bus file {p}: {exc}") from None


def default_bus_config(path: str | os.PathLike | None = None) -> BusConfig:
    """``path``, else the file named by ``$GAITCAP_BUS``, else :meth:`BusConfig.local`."""
    chosen = path or os.environ.get(BUS_ENV)
    return load_bus_config(chosen) if chosen else BusConfig.local()


def zenoh_config(bus: BusConfig, node: str | None):
    """The ``zenoh.Config`` of ``node`` (None: a client that only connects)."""
    import zenoh

    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("scouting/gossip/enabled", "false")
    conf.insert_json5("listen/endpoints", json.dumps(bus.listen_for(node)))
    conf.insert_json5("connect/endpoints", json.dumps(bus.connect_for(node)))
    conf.insert_json5("connect/retry", '{"period_init_ms": 200, "period_max_ms": 1000, "period_increase_factor": 2}')
    conf.insert_json5("transport/link/tx/lease", str(int(bus.lease_ms)))
    # Zenoh's shared-memory transport (on by default) maps each local sender's 16 MB pool into every receiver
    # of its large messages and keeps it after the sender dies: +19 MB in the recorder, detector and API for
    # each restart of the camera process (docs/benchmarks.md, "What the recorder, detector, API and worker kept
    # over the 120-minute day"). Loopback TCP carries the clinic's images (10 x 30 fps x ~30 kB) easily.
    conf.insert_json5("transport/shared_memory/enabled", "false")
    if bus.security is not None:
        if node is None:
            raise ValueError("bus: this bus is secured; give the identity to connect as (--node NAME, a node "
                             "or a security.clients entry)")
        for path, value in zenoh_security(bus.security, node, prefix=bus.prefix, identities=bus.identities).items():
            conf.insert_json5(path, json.dumps(value))
    return conf


def open_session(bus: BusConfig, node: str | None = None):
    """Open a Zenoh peer session for ``node`` (listening on its endpoint when it has one)."""
    import zenoh

    if node is not None:
        check_name(node, what="node")
    conf = zenoh_config(bus, node)
    if bus.security is None and bus.listen_for(node):
        where = "loopback only" if bus.loopback_only else "BEYOND LOOPBACK (insecure_plain)"
        log.warning("bus %s: plain TCP, %s: no authentication, any process that reaches it can use it",
                    bus.prefix, where)
    try:
        return zenoh.open(conf)
    except zenoh.ZError as exc:
        where = bus.listen_for(node)
        raise ValueError(f"bus: cannot open a session for node {node!r} (listen {where}): {exc}") from None


def declare_alive(session, bus: BusConfig, node: str):
    """Hold the node's liveliness token ``<prefix>/alive/<node>`` (keep the returned object alive)."""
    return session.liveliness().declare_token(bus.keys.alive(node))


def watch_alive(session, bus: BusConfig, on_change: Callable[[str, bool], None]):
    """Call ``on_change(node, alive)`` for nodes present now and whenever one appears or dies."""
    import zenoh

    keys = bus.keys

    def _cb(sample) -> None:
        on_change(keys.node_of(str(sample.key_expr)), sample.kind == zenoh.SampleKind.PUT)

    return session.liveliness().declare_subscriber(keys.alive(), _cb, history=True)


def alive_nodes(session, bus: BusConfig, timeout_s: float = 1.0) -> set[str]:
    """Names of the nodes holding a liveliness token now."""
    keys = bus.keys
    replies = session.liveliness().get(keys.alive(), timeout=timeout_s)
    return {keys.node_of(str(r.ok.key_expr)) for r in replies if r.ok is not None}


def free_loopback_ports(n: int, *, low: int = 20000, high: int | None = None) -> list[int]:
    """``n`` consecutive TCP ports free on 127.0.0.1 right now, ``base, base + 1, ...`` between ``low`` and
    ``high`` (test, benchmark and demo stacks on loopback: a bus's nodes, an API port and the bus after it).
    ``high`` defaults to the start of the kernel's ephemeral range, so that no outgoing connection is given
    one of these ports between this check and the bind. The base is drawn from the OS's entropy, not the
    ``random`` module's state, so that processes that seed ``random`` alike (test runners do) still draw
    different ports; a port bound by any process is skipped."""
    high = _ephemeral_start() if high is None else high
    draw = random.SystemRandom()
    for _ in range(200):
        base = draw.randrange(low, high - n + 1)  # the last port, base + n - 1, below high
        if all(_port_free(base + i) for i in range(n)):
            return list(range(base, base + n))
    raise RuntimeError(f"no {n} consecutive free ports on 127.0.0.1 between {low} and {high}")


def _ephemeral_start(path: str = "/proc/sys/net/ipv4/ip_local_port_range", fallback: int = 32768) -> int:
    """The first port the kernel hands to outgoing connections (Linux; ``fallback`` elsewhere)."""
    try:
        first = int(Path(path).read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return fallback
    return first if first > 21000 else fallback  # a range starting below 21000 leaves the stacks too few ports


def _port_free(port: int) -> bool:
    with socket.socket() as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True
