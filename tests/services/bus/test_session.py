import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from gaitcap.services.bus.session import (
    BusConfig,
    _port_free,
    alive_nodes,
    declare_alive,
    default_bus_config,
    free_loopback_ports,
    load_bus_config,
    open_session,
    watch_alive,
    zenoh_config,
)

ROOT = Path(__file__).resolve().parents[3]


def free_bus(names, prefix="gaitcap/test"):
    return BusConfig.free_local(names, prefix=prefix)


def test_bus_file_json5(tmp_path):
    f = tmp_path / "rig.json5"
    f.write_text("""{
      // two hosts
      prefix: 'gaitcap/lab1',
      lease_ms: 2000,
      insecure_plain: true,  // a plain bus beyond loopback must be asked for
      nodes: {
        "camera-0": "tcp/192.168.50.10:7447",   /* acquisition PC */
        recorder: "tcp/192.168.50.20:7447",
      },
    }""")
    cfg = load_bus_config(f)
    assert cfg.prefix == "gaitcap/lab1" and cfg.lease_ms == 2000
    assert cfg.listen_for("recorder") == ["tcp/192.168.50.20:7447"]
    assert cfg.connect_for("recorder") == ["tcp/192.168.50.10:7447"]
    assert cfg.listen_for("cli") == [] and len(cfg.connect_for("cli")) == 2


def test_shipped_deploy_configs_load():
    files = sorted((ROOT / "deploy" / "zenoh").glob("*.json5"))
    assert files
    for f in files:
        cfg = load_bus_config(f)
        assert any(n.startswith("camera") for n in cfg.nodes) and "recorder" in cfg.nodes
        assert cfg.security is not None and all(e.startswith("tls/") for e in cfg.nodes.values()), f.name


@pytest.mark.parametrize("text,match", [
    ('{"nodes": {"a": "127.0.0.1:1"}}', "endpoint"),
    ('{"nodes": {"a b": "tcp/127.0.0.1:1"}}', "bus node"),
    ('{"nodes": {}, "color": 1}', "unknown fields"),
    ('{"nodes": {"a": "tcp/h:1", "b": "tcp/h:1"}}', "used twice"),
    ("{nodes: ", "not valid JSON5"),
])
def test_bad_bus_files(tmp_path, text, match):
    f = tmp_path / "bad.json5"
    f.write_text(text)
    with pytest.raises(ValueError, match=match):
        load_bus_config(f)


def test_default_is_local_peer_without_scouting(monkeypatch, tmp_path):
    monkeypatch.delenv("GAITCAP_BUS", raising=False)
    cfg = default_bus_config()
    assert cfg.nodes["recorder"] == "tcp/127.0.0.1:7447"
    conf = json.loads(str(zenoh_config(cfg, "recorder")))
    assert conf["mode"] == "peer"
    assert conf["scouting"]["multicast"]["enabled"] is False and conf["scouting"]["gossip"]["enabled"] is False
    assert conf["listen"]["endpoints"] == ["tcp/127.0.0.1:7447"]
    assert "tcp/127.0.0.1:7447" not in conf["connect"]["endpoints"]
    f = tmp_path / "b.json"
    f.write_text(json.dumps({"nodes": {"x": "tcp/127.0.0.1:9"}}))
    monkeypatch.setenv("GAITCAP_BUS", str(f))
    assert default_bus_config().nodes == {"x": "tcp/127.0.0.1:9"}


def test_peers_exchange_and_liveliness_sees_a_killed_node():
    bus = free_bus(["a", "b"])
    sa = open_session(bus, "a")
    got, changes = [], []
    done = threading.Event()
    sub = sa.declare_subscriber(f"{bus.prefix}/t", lambda s: (got.append(s.payload.to_bytes()), done.set()))
    watcher = watch_alive(sa, bus, lambda node, alive: changes.append((node, alive)))
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    code = (
        "import sys, time, json\n"
        "from gaitcap.services.bus.session import BusConfig, open_session, declare_alive\n"
        f"bus = BusConfig(json.loads({json.dumps(json.dumps(bus.nodes))}), prefix={bus.prefix!r})\n"
        "s = open_session(bus, 'b'); tok = declare_alive(s, bus, 'b')\n"
        "time.sleep(0.5)\n"
        "while True:\n"
        f"    s.put({bus.prefix + '/t'!r}, b'hello'); time.sleep(0.1)\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", code], env=env, cwd=str(ROOT))
    try:
        assert done.wait(20), "no message from the peer process"
        assert got[0] == b"hello"
        deadline = time.monotonic() + 10
        while ("b", True) not in changes and time.monotonic() < deadline:
            time.sleep(0.05)
        assert ("b", True) in changes and "b" in alive_nodes(sa, bus)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        t0 = time.monotonic()
        while ("b", False) not in changes and time.monotonic() - t0 < 5:
            time.sleep(0.02)
        assert ("b", False) in changes, "killed node not seen gone"
        assert time.monotonic() - t0 < 2.0
    finally:
        proc.kill()
        sub.undeclare()
        watcher.undeclare()
        sa.close()


def test_own_token_and_bad_node_name():
    bus = free_bus(["n1"])
    s = open_session(bus, "n1")
    try:
        tok = declare_alive(s, bus, "n1")
        assert alive_nodes(s, bus) == {"n1"}
        tok.undeclare()
        with pytest.raises(ValueError, match="node"):
            open_session(bus, "bad/name")
    finally:
        s.close()


def test_free_loopback_ports_skip_a_bound_port_and_not_follow_the_random_seed():
    import random
    import socket

    with socket.socket() as held:  # a port another socket listens on is never handed out
        held.bind(("127.0.0.1", 0))
        held.listen()
        p = held.getsockname()[1]
        if not _port_free(p + 1):
            pytest.skip(f"port {p + 1} is in use here")
        for _ in range(10):  # bases p or p + 1 can be drawn: p is held
            assert free_loopback_ports(1, low=p, high=p + 2) == [p + 1]
        with pytest.raises(RuntimeError, match="no 2 consecutive free ports"):
            free_loopback_ports(2, low=p - 1, high=p + 2)  # both possible pairs include p
    bases = []
    for _ in range(3):  # processes seeding random alike (test runners do) draw different ports
        random.seed(0)
        ports = free_loopback_ports(4)
        assert ports == list(range(ports[0], ports[0] + 4))
        bases.append(ports[0])
    assert len(set(bases)) > 1, bases




def test_free_loopback_ports_stay_below_the_kernels_ephemeral_range(tmp_path):
    from gaitcap.services.bus.session import _ephemeral_start

    ranges = tmp_path / "ip_local_port_range"
    ranges.write_text("40000\t60999\n")
    assert _ephemeral_start(str(ranges)) == 40000
    ranges.write_text("not a range\n")
    assert _ephemeral_start(str(ranges)) == 32768 == _ephemeral_start(str(tmp_path / "absent"))
    first = _ephemeral_start()
    for _ in range(20):
        ports = free_loopback_ports(4)
        assert 20000 <= ports[0] and ports[-1] < first, (ports, first)


def _rss_mb() -> float:
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmRSS")) / 1024


def test_a_peer_restarted_with_large_messages_leaves_no_memory_behind():
    """A camera process killed and restarted (a working day's fault) must not leave the memory of its links in
    the peers that received its images: with Zenoh's shared-memory transport each life of a sender of large
    messages left its 16 MB pool mapped in every receiver for good (+19 MB a restart in the recorder, the
    detector and the API over the 120-minute soak)."""
    bus = free_bus(["rx", "tx"], prefix="gaitcap/shmtest")
    assert zenoh_config(bus, "rx").get_json("transport/shared_memory/enabled") == "false"
    rx = open_session(bus, "rx")
    counts = []
    sub = rx.declare_subscriber(f"{bus.prefix}/img", lambda s: counts.append(len(s.payload.to_bytes())))
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    code = (
        "import time, json\n"
        "from gaitcap.services.bus.session import BusConfig, open_session\n"
        f"bus = BusConfig(json.loads({json.dumps(json.dumps(bus.nodes))}), prefix={bus.prefix!r})\n"
        "s = open_session(bus, 'tx'); payload = bytes(range(256)) * 120\n"
        "while True:\n"
        f"    s.put({bus.prefix + '/img'!r}, payload); time.sleep(0.005)\n"
    )
    rss = []
    try:
        for _life in range(3):
            before = len(counts)
            proc = subprocess.Popen([sys.executable, "-c", code], env=env, cwd=str(ROOT))
            try:
                deadline = time.monotonic() + 20
                while len(counts) < before + 200 and time.monotonic() < deadline:
                    time.sleep(0.05)
                assert len(counts) >= before + 200, "the sender's messages did not arrive"
            finally:
                proc.send_signal(signal.SIGKILL)
                proc.wait()
            time.sleep(0.3)
            rss.append(_rss_mb())
        assert set(counts) == {30720}
        assert rss[-1] - rss[0] < 8.0, f"the receiver kept memory of the killed senders: RSS {rss} MB"
    finally:
        sub.undeclare()
        rx.close()
