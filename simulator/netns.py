"""Network namespaces and veth links for the multi-host tests, the fake GigE Vision cameras and their bench
(Linux, root, iproute2): the one place that makes and removes them.

:func:`namespace_unavailable` says why they cannot be made here ("" when they can);
:func:`add_namespace` makes one with its loopback up (and extra loopback addresses);
:func:`add_veth` joins two namespaces, or a namespace and this host, by a veth pair with an IPv4 address
at each end; :func:`delete_namespace` removes one with every link in it. A command that fails raises
ValueError naming it and what ``ip`` said.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from collections.abc import Sequence
from dataclasses import dataclass

IP_TIMEOUT_S = 20


def ip(*args: str) -> subprocess.CompletedProcess:
    """``ip ARGS`` (never raises on a failed command: see :func:`ip_or_fail`)."""
    return subprocess.run(["ip", *args], capture_output=True, text=True, timeout=IP_TIMEOUT_S)


def ip_or_fail(*args: str, what: str) -> None:
    """``ip ARGS``; ValueError naming ``what``, the command and ``ip``'s message when it fails."""
    r = ip(*args)
    if r.returncode != 0:
        raise ValueError(f"{what}: ip {' '.join(args)}: {r.stderr.strip()}")


def exec_prefix(namespace: str | None) -> list[str]:
    """Prefix that runs a command in ``namespace`` (nothing for this host's own)."""
    return ["ip", "netns", "exec", namespace] if namespace else []


def namespace_unavailable() -> str:
    """Why network namespaces cannot be made here ("" when they can): not root, no ``ip``, or a probe
    namespace that cannot be made or entered."""
    if os.geteuid() != 0:
        return "needs root to create network namespaces"
    if shutil.which("ip") is None:
        return "the 'ip' command (iproute2) is not installed"
    probe = f"gcprobe{os.getpid() % 100000}"
    r = ip("netns", "add", probe)
    if r.returncode != 0:
        return f"'ip netns add' failed: {r.stderr.strip()}"
    try:
        r = ip("netns", "exec", probe, "true")
        return "" if r.returncode == 0 else f"'ip netns exec' failed: {r.stderr.strip()}"
    finally:
        ip("netns", "del", probe)


def add_namespace(name: str, *, loopback_addresses: Sequence[str] = (), what: str = "network namespace") -> None:
    """Namespace ``name`` with its loopback up and ``loopback_addresses`` (``a.b.c.d/len``) on it."""
    ip_or_fail("netns", "add", name, what=what)
    ip_or_fail("-n", name, "link", "set", "lo", "up", what=what)
    for addr in loopback_addresses:
        ip_or_fail("-n", name, "addr", "add", addr, "dev", "lo", what=what)


def delete_namespace(name: str) -> None:
    """Remove namespace ``name`` and every link in it (a veth pair goes with either of its ends)."""
    ip("netns", "del", name)


@dataclass(frozen=True)
class VethEnd:
    """One end of a veth pair: interface ``name`` in ``namespace`` (None: this host's own) with IPv4
    ``addresses`` (``a.b.c.d/len``, the first is its main one)."""

    name: str
    namespace: str | None
    addresses: tuple[str, ...]

    def __post_init__(self) -> None:
        if not 1 <= len(self.name) <= 15:
            raise ValueError(f"veth end {self.name!r}: an interface name has 1..15 characters")
        if not self.addresses or any("/" not in a for a in self.addresses):
            raise ValueError(f"veth end {self.name}: addresses as a.b.c.d/len needed, got {self.addresses}")

    @property
    def address(self) -> str:
        """The main address without its prefix length."""
        return self.addresses[0].split("/")[0]


def add_veth(a: VethEnd, b: VethEnd, *, mtu_bytes: int = 1500, what: str = "veth link") -> None:
    """A veth pair from ``a`` to ``b``, addressed, with MTU ``mtu_bytes`` (9000: jumbo frames), up.
    On failure the pair is removed (:func:`delete_veth`) before the error is raised."""
    try:
        ip_or_fail("link", "add", a.name, "type", "veth", "peer", "name", b.name, what=what)
        for end in (a, b):
            if end.namespace:
                ip_or_fail("link", "set", end.name, "netns", end.namespace, what=what)
            on = ["-n", end.namespace] if end.namespace else []
            ip_or_fail(*on, "link", "set", end.name, "mtu", str(mtu_bytes), what=what)
            for addr in end.addresses:
                ip_or_fail(*on, "addr", "add", addr, "dev", end.name, what=what)
            ip_or_fail(*on, "link", "set", end.name, "up", what=what)
    except ValueError:
        delete_veth(a)
        raise


def delete_veth(end: VethEnd) -> None:
    """Remove the veth pair of ``end`` (both ends go; nothing happens where it is already gone)."""
    ip(*(["-n", end.namespace] if end.namespace else []), "link", "del", end.name)
    if end.namespace:
        ip("link", "del", end.name)  # it may never have left this host's namespace
