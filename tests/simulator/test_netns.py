"""The network namespace helper shared by the fake GigE Vision lab and the two-host test: a namespace and
a veth link to this host really made (root and iproute2; skipped with the reason otherwise), addresses
reachable, everything gone afterwards; bad ends refused naming what is wrong."""

import os
import socket
import subprocess
import sys

import pytest
from gaitcap.simulator import netns


def test_a_veth_end_names_what_is_wrong():
    with pytest.raises(ValueError, match="1..15 characters"):
        netns.VethEnd("a-much-too-long-name", None, ("10.0.0.1/24",))
    with pytest.raises(ValueError, match="a.b.c.d/len"):
        netns.VethEnd("gcx", None, ("10.0.0.1",))


def test_a_namespace_linked_to_this_host_is_reachable_and_removed():
    reason = netns.namespace_unavailable()
    if reason:
        pytest.skip(reason)
    tag = os.getpid() % 100000
    ns, subnet = f"gcnstest{tag}", f"10.233.{10 + os.getpid() % 200}"
    host = netns.VethEnd(f"gcnh{tag}", None, (f"{subnet}.1/24",))
    far = netns.VethEnd(f"gcnf{tag}", ns, (f"{subnet}.2/24", f"{subnet}.3/24"))
    try:
        netns.add_namespace(ns, loopback_addresses=("127.0.0.9/8",))
        netns.add_veth(host, far, mtu_bytes=9000)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as rx:
            rx.bind((host.address, 0))
            rx.settimeout(10)
            # from the far end, 8000 bytes with "don't fragment": jumbo frames cross the link whole
            send = (f"import socket; s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); "
                    f"s.setsockopt(socket.IPPROTO_IP, 10, 2); s.bind(('{far.address}', 0)); "
                    f"s.sendto(b'x' * 8000, ('{host.address}', {rx.getsockname()[1]}))")
            r = subprocess.run([*netns.exec_prefix(ns), sys.executable, "-c", send], capture_output=True, text=True,
                               timeout=30)
            assert r.returncode == 0, r.stderr
            data, (sender, _) = rx.recvfrom(65535)
        assert (len(data), sender) == (8000, far.address)
        with pytest.raises(ValueError, match=rf"veth link: ip link add gcnh{tag} .*"):
            netns.add_veth(host, far)  # the pair exists already: named, and removed on the way out
    finally:
        netns.delete_namespace(ns)
        netns.delete_veth(host)
    links = subprocess.run(["ip", "-o", "link"], capture_output=True, text=True).stdout
    assert f"gcnh{tag}" not in links and ns not in subprocess.run(["ip", "netns", "list"], capture_output=True,
                                                                  text=True).stdout
