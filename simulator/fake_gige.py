"""Fake GigE Vision cameras: ``arv-fake-gv-camera-0.8`` processes (Debian package aravis-tools) speaking the
real protocol (GVCP control, GVSP stream over UDP), for tests and ``bench/gige.py``.

One fake camera listens on one IPv4 address of an interface. On the host, only 127.0.0.1 exists, so one
camera runs there (:func:`host_lab`). Several cameras run in a network namespace of their own
(:class:`FakeGigELab` with ``namespace=True``; :mod:`gaitcap.simulator.netns` makes it), in one of two
places:

- on the namespace's loopback (the default): one address per camera (127.0.0.11, 127.0.0.12, ...), and
  the processes that talk to them (camera nodes, the bench) run in the same namespace through
  :attr:`FakeGigELab.exec_prefix`;
- behind a link (``host_link=True``), as on a real rig: the namespace is joined to this host by a veth
  pair with jumbo frames (MTU 9000), the cameras on its far end (10.232.S.11, .12, ...), this host on
  10.232.S.1; the processes that talk to them run on this host (``exec_prefix`` is empty), so the rest of
  the stack needs no namespace.

Faults: :meth:`FakeGigELab.kill` (a camera vanishes), ``lost_per_thousand`` (GVSP packets the camera never
sends: random loss on its link), :meth:`FakeGigELab.shape` (``tc`` on the cameras' side of their link: one
camera's stream through ``netem`` loss and delay where the kernel has it, else through a rate limit that
delays it and a queue that drops it; which one ran is in what it returns).

The fake camera streams a 512 x 512 test pattern (nobody in it), its timestamps are the host clock in ns
and it fires on the host clock's frame grid; it has no PTP, no action commands and does not answer
packet resend requests (resend requests are counted, resent packets stay 0).
"""

from __future__ import annotations

import contextlib
import logging
import os
import shutil
import signal
import subprocess
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

from gaitcap.simulator import netns

log = logging.getLogger(__name__)

FAKE_CAMERA = "arv-fake-gv-camera-0.8"
GVCP_PORT = 3956
FAKE_SIZE_PX = (512, 512)


def fake_camera_binary() -> str:
    """Path of the fake camera program (ValueError naming the package when it is absent)."""
    path = shutil.which(FAKE_CAMERA)
    if path is None:
        raise ValueError(f"{FAKE_CAMERA} not found: install the Debian package aravis-tools "
                         "(deploy/bootstrap.sh does)")
    return path


namespace_unavailable = netns.namespace_unavailable
LINK_MTU_BYTES = 9000  # jumbo frames on the link of a lab behind a link


@dataclass
class FakeCamera:
    """One running fake camera: its serial number, address and process."""

    serial: str
    address: str
    process: subprocess.Popen


class FakeGigELab:
    """``cameras`` fake GigE Vision cameras, serials ``GC001``.., in a namespace of their own (on its
    loopback, or behind a link to this host with ``host_link``) or on the host's 127.0.0.1 (one camera).
    Use as a context manager; everything is removed on exit."""

    def __init__(self, cameras: int = 1, *, namespace: bool = True, host_link: bool = False,
                 lost_per_thousand: int | Sequence[int] = 0, log_dir: Path | None = None,
                 ready_timeout_s: float = 10.0) -> None:
        if cameras < 1 or (not namespace and cameras != 1):
            raise ValueError(f"cameras: {cameras} fake cameras need a namespace (the host has one loopback "
                             "address: 1 camera)" if cameras > 1 else f"cameras: must be >= 1, got {cameras}")
        if host_link and not namespace:
            raise ValueError("host_link: cameras behind a link need a namespace of their own")
        if cameras > 200:
            raise ValueError(f"cameras: at most 200 fake cameras, got {cameras}")
        lost = (lost_per_thousand,) * cameras if isinstance(lost_per_thousand, int) else tuple(lost_per_thousand)
        if len(lost) != cameras or not all(0 <= k <= 1000 for k in lost):
            raise ValueError(f"lost_per_thousand: expected 0..1000 (one or one per camera), got {lost_per_thousand}")
        self.count, self.lost_per_thousand = cameras, lost
        self.log_dir, self.ready_timeout_s = log_dir, ready_timeout_s
        tag = os.getpid() % 100000
        self.namespace = f"gcgige{tag}" if namespace else None
        self.link: tuple[netns.VethEnd, netns.VethEnd] | None = None
        if host_link:
            subnet = f"10.232.{10 + os.getpid() % 200}"
            self.link = (netns.VethEnd(f"gcgh{tag}", None, (f"{subnet}.1/24",)),
                         netns.VethEnd(f"gcgc{tag}", self.namespace,
                                       tuple(f"{subnet}.{11 + i}/24" for i in range(cameras))))
        self.cameras: list[FakeCamera] = []

    @property
    def exec_prefix(self) -> list[str]:
        """Prefix that runs a command where the cameras are reachable: the namespace, or nothing (the host's
        127.0.0.1, or a lab behind a link)."""
        return [] if self.link else netns.exec_prefix(self.namespace)

    @property
    def host_address(self) -> str | None:
        """This host's address on the cameras' link (None: no link)."""
        return self.link[0].address if self.link else None

    @property
    def addresses(self) -> list[str]:
        return [c.address for c in self.cameras]

    @property
    def serials(self) -> list[str]:
        return [c.serial for c in self.cameras]

    def __enter__(self) -> FakeGigELab:
        try:
            self.start()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def start(self) -> None:
        binary = fake_camera_binary()
        if self.namespace:
            reason = namespace_unavailable()
            if reason:
                raise ValueError(f"fake GigE Vision lab: {reason}")
            self._ns_up()
        for i, addr in enumerate(self._camera_addresses()):
            self.cameras.append(self._spawn(binary, f"GC{i + 1:03d}", addr, self.lost_per_thousand[i]))
        for cam in self.cameras:
            self._wait_ready(cam)

    def _camera_addresses(self) -> list[str]:
        if self.link:
            return [a.split("/")[0] for a in self.link[1].addresses]
        return [f"127.0.0.{11 + i}" for i in range(self.count)] if self.namespace else ["127.0.0.1"]

    def _ns_up(self) -> None:
        what = "fake GigE Vision lab"
        loopback = () if self.link else tuple(f"127.0.0.{11 + i}/8" for i in range(self.count))
        netns.add_namespace(self.namespace, loopback_addresses=loopback, what=what)
        if self.link:
            netns.add_veth(*self.link, mtu_bytes=LINK_MTU_BYTES, what=what)

    @property
    def _camera_prefix(self) -> list[str]:
        """Prefix that runs a command beside the cameras (in their namespace)."""
        return netns.exec_prefix(self.namespace)

    @property
    def _egress_device(self) -> str:
        """The interface the cameras' streams leave by (where :meth:`shape` acts)."""
        return self.link[1].name if self.link else "lo"

    def _spawn(self, binary: str, serial: str, address: str, lost_per_thousand: int) -> FakeCamera:
        argv = [*self._camera_prefix, binary, "-i", address, "-s", serial]
        if lost_per_thousand:
            argv += ["-r", str(lost_per_thousand)]
        out = open(self.log_dir / f"fake-{serial}.log", "wb") if self.log_dir else subprocess.DEVNULL  # noqa: SIM115
        proc = subprocess.Popen(argv, stdout=out, stderr=subprocess.STDOUT, start_new_session=True)
        return FakeCamera(serial=serial, address=address, process=proc)

    def _wait_ready(self, cam: FakeCamera) -> None:
        """Until the camera's GVCP port is bound (ValueError naming it if it exits or never binds)."""
        deadline = time.monotonic() + self.ready_timeout_s
        while time.monotonic() < deadline:
            if cam.process.poll() is not None:
                raise ValueError(f"fake camera {cam.serial} on {cam.address} exited ({cam.process.returncode})")
            r = subprocess.run([*self._camera_prefix, "ss", "-Hlun", "src", f"{cam.address}:{GVCP_PORT}"],
                               capture_output=True, text=True, timeout=10)
            if f"{cam.address}:{GVCP_PORT}" in r.stdout:
                return
            time.sleep(0.05)
        raise ValueError(f"fake camera {cam.serial} on {cam.address}: not listening after {self.ready_timeout_s} s")

    def kill(self, index: int) -> FakeCamera:
        """SIGKILL camera ``index`` (it vanishes from the network mid-stream)."""
        cam = self.cameras[index]
        with contextlib.suppress(ProcessLookupError):
            os.killpg(cam.process.pid, signal.SIGKILL)
        cam.process.wait(10)
        return cam

    def shape(self, *, source: str, loss_percent: float = 0.0, delay_ms: float = 0.0, rate_mbit: float = 50.0,
              queue_packets: int = 20) -> str:
        """Make the link from camera address ``source`` lossy and slow with ``tc`` where the cameras' streams
        leave (the namespace's loopback, or its end of the link); returns what was applied, naming the branch
        that ran (``netem`` or, where the kernel lacks it, ``pfifo``). Only that camera's GVSP stream is
        touched (its GVCP answers, from port 3956, pass, as does the bus): an ``htb`` class at ``rate_mbit`` takes the stream, and under it
        ``netem`` (``loss_percent``, ``delay_ms``) where the kernel has it, else a ``pfifo`` of
        ``queue_packets``: the rate limit delays packets and the full queue drops them (a real loss on the
        path). ValueError naming the command that failed.
        """
        if not self.namespace:
            raise ValueError("shape: traffic shaping needs the lab's own namespace")
        tc, dev = ["tc", "-n", self.namespace], self._egress_device
        self.unshape()
        for argv in (["qdisc", "add", "dev", dev, "root", "handle", "1:", "htb", "default", "10", "r2q", "1000"],
                     ["class", "add", "dev", dev, "parent", "1:", "classid", "1:10", "htb", "rate", "10gbit"],
                     ["class", "add", "dev", dev, "parent", "1:", "classid", "1:20", "htb", "rate",
                      f"{rate_mbit}mbit", "ceil", f"{rate_mbit}mbit"],
                     ["filter", "add", "dev", dev, "parent", "1:", "protocol", "ip", "prio", "1", "u32", "match",
                      "ip", "src", f"{source}/32", "match", "ip", "sport", str(GVCP_PORT), "0xffff", "flowid", "1:10"],
                     ["filter", "add", "dev", dev, "parent", "1:", "protocol", "ip", "prio", "2", "u32", "match",
                      "ip", "src", f"{source}/32", "flowid", "1:20"]):
            self._tc(tc + argv)
        leaf = ["qdisc", "add", "dev", dev, "parent", "1:20", "handle", "20:"]
        netem = ["netem", "loss", f"{loss_percent}%", "delay", f"{delay_ms}ms"]
        r = subprocess.run(tc + leaf + netem, capture_output=True, text=True, timeout=20)
        if r.returncode == 0:
            applied = f"{source}: htb {rate_mbit} Mbit/s, " + " ".join(netem)
        else:
            self._tc(tc + leaf + ["pfifo", "limit", str(queue_packets)])
            applied = (f"{source}: htb {rate_mbit} Mbit/s, pfifo {queue_packets} packets (netem unavailable in "
                       f"this kernel: {r.stderr.strip()})")
        log.info("fake GigE Vision lab: link shaped: %s", applied)
        return applied

    @staticmethod
    def _tc(argv: list[str]) -> None:
        r = subprocess.run(argv, capture_output=True, text=True, timeout=20)
        if r.returncode != 0:
            raise ValueError(f"shape: {' '.join(argv)}: {r.stderr.strip()}")

    def unshape(self) -> None:
        if self.namespace:
            subprocess.run(["tc", "-n", self.namespace, "qdisc", "del", "dev", self._egress_device, "root"],
                           capture_output=True, timeout=20)

    def close(self) -> None:
        for cam in self.cameras:
            if cam.process.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(cam.process.pid, signal.SIGTERM)
        for cam in self.cameras:
            try:
                cam.process.wait(5)
            except subprocess.TimeoutExpired:
                os.killpg(cam.process.pid, signal.SIGKILL)
                cam.process.wait(5)
        self.cameras.clear()
        if self.link:
            netns.delete_veth(self.link[0])
        if self.namespace:
            netns.delete_namespace(self.namespace)


@contextlib.contextmanager
def host_lab(**kwargs) -> Iterator[FakeGigELab]:
    """One fake camera on the host's 127.0.0.1."""
    with FakeGigELab(1, namespace=False, **kwargs) as lab:
        yield lab
