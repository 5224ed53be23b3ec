"""The secured bus, for real (Zenoh over TLS on loopback): mutual TLS with the lab CA made by
``make_bus_keys``, user/password, and access control by node role."""

import json
import stat
import time

import pytest
from gaitcap.services.bus.certs import make_bus_keys
from gaitcap.services.bus.control import RecorderClient, RecorderError
from gaitcap.services.bus.messages import ImageFrame
from gaitcap.services.bus.security import BusSecurity, may_send, role_of
from gaitcap.services.bus.session import (
    BusConfig,
    alive_nodes,
    free_loopback_ports,
    load_bus_config,
    open_session,
)
from gaitcap.services.nodes.recorder import RecorderNode

JPEG = bytes.fromhex("ffd8ffe000104a464946") + b"\x00" * 20 + bytes.fromhex("ffd9")



def _wait(cond, timeout_s=10.0):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(0.05)
    return False


@pytest.fixture(scope="module")
def secured(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("secure")
    names = ["recorder", "api", "camera-0"]
    nodes = {n: f"tls/127.0.0.1:{p}" for n, p in zip(names, free_loopback_ports(3), strict=True)}
    bus = BusConfig(nodes, prefix="gaitcap/sec", security=BusSecurity(tmp / "keys", clients=("operator",),
                                                                     cameras={"camera-0": ("cam01",)}))
    made = make_bus_keys({n: bus.nodes.get(n) for n in bus.identities}, tmp / "keys")
    assert made == ["recorder", "api", "camera-0", "operator"]
    other_ca = make_bus_keys({"api": nodes["api"]}, tmp / "other-ca")  # a valid-looking cert, wrong CA
    assert other_ca == ["api"]
    (tmp / "data").mkdir()
    srec = open_session(bus, "recorder")
    rec = RecorderNode(srec, bus, data_root=tmp / "data")
    yield bus, tmp
    rec.close()
    srec.close()


def test_keys_are_private_and_the_bus_file_round_trips(secured, tmp_path):
    bus, tmp = secured
    keys = tmp / "keys"
    assert stat.S_IMODE(keys.stat().st_mode) == 0o700
    for f in ("ca.key", "recorder.key", "passwords.txt"):
        assert stat.S_IMODE((keys / f).stat().st_mode) == 0o600, f
    f = tmp_path / "bus.json5"
    f.write_text(json.dumps(bus.to_dict()))
    assert load_bus_config(f) == bus
    assert make_bus_keys({"recorder": None}, keys) == []  # kept, not overwritten
    assert [role_of(n) for n in ("camera-3", "worker-1", "recorder", "api", "operator")] == \
        ["camera", "worker", "recorder", "api", "client"]
    fetch = ("query", "recorder/recording/T1")  # what the roles' table lets each send (the others' check)
    assert [may_send(n, *fetch) for n in ("worker-gpu", "api", "camera-9", "recorder", "operator")] == \
        [True, True, False, False, False]
    assert may_send("api", "query", "recorder/start") and not may_send("worker-gpu", "query", "recorder/start")
    assert may_send("recorder", "reply", "recorder/recording/T1") and not may_send("worker-1", "put", "camera/c/image")


def test_plain_bus_beyond_loopback_is_refused_unless_told():
    with pytest.raises(ValueError, match="beyond loopback without security"):
        BusConfig({"recorder": "tcp/192.168.1.2:7447"})
    assert BusConfig({"recorder": "tcp/192.168.1.2:7447"}, insecure_plain=True).insecure_plain
    with pytest.raises(ValueError, match="must listen on tls/ endpoints"):
        BusConfig({"recorder": "tcp/127.0.0.1:7447"}, security=BusSecurity("/nowhere"))


def test_api_may_record_but_a_camera_may_not_start_the_recorder(secured):
    bus, _ = secured
    api, cam = open_session(bus, "api"), open_session(bus, "camera-0")
    try:
        assert _wait(lambda: "recorder" in alive_nodes(api, bus)), "api does not see the recorder over TLS"
        assert _wait(lambda: "recorder" in alive_nodes(cam, bus))
        with pytest.raises(RecorderError, match="no recorder answered"):
            RecorderClient(cam, bus.keys, timeout_s=1.0).start(trial_id="evil", path="evil.mcap")
        got = []
        sub = api.declare_subscriber(f"{bus.prefix}/**", lambda s: got.append(str(s.key_expr)))
        time.sleep(0.5)
        frame = ImageFrame.build(JPEG, camera="cam01", timestamp_ns=1, frame_id=0, sent_ns=1)
        cam.put(bus.keys.image("cam01"), frame.payload, attachment=frame.meta.to_bytes())
        cam.put(bus.keys.image("cam02"), frame.payload, attachment=frame.meta.to_bytes())  # not its camera
        cam.put(bus.keys.keypoints("cam01"), b"{}")  # a camera may not publish keypoints
        cam.put(bus.keys.recorder_events, b"{}")
        assert _wait(lambda: bus.keys.image("cam01") in got)
        time.sleep(0.3)
        assert got == [bus.keys.image("cam01")]
        client = RecorderClient(api, bus.keys, timeout_s=5)
        assert client.start(trial_id="t1", path="t1.mcap").ok
        assert client.stop("t1").ok
        sub.undeclare()
    finally:
        api.close()
        cam.close()


def _intruder(bus, tmp, node, *, keys_dir=None, password=None, plain=False):
    if plain:
        plain_bus = BusConfig({"recorder": bus.nodes["recorder"].replace("tls/", "tcp/")}, prefix=bus.prefix)
        return open_session(plain_bus)
    sec = BusSecurity(keys_dir or bus.security.keys_dir, clients=(node,))
    if password is not None:
        fake = tmp / f"fake-{node}"
        fake.mkdir(exist_ok=True)
        for f in ("ca.pem", f"{node}.pem", f"{node}.key"):
            (fake / f).write_bytes((sec.keys_dir / f).read_bytes())
        (fake / "passwords.txt").write_text(f"{node}:{password}\n")
        sec = BusSecurity(fake, clients=(node,))
    return open_session(BusConfig({"recorder": bus.nodes["recorder"]}, prefix=bus.prefix, security=sec), node)


@pytest.mark.parametrize("how", ["plain tcp", "certificate of another CA", "right certificate, wrong password"])
def test_a_peer_without_credentials_can_do_nothing(secured, how):
    bus, tmp = secured
    s = {"plain tcp": lambda: _intruder(bus, tmp, None, plain=True),
         "certificate of another CA": lambda: _intruder(bus, tmp, "api", keys_dir=tmp / "other-ca",
                                                        password="x" * 43),
         "right certificate, wrong password": lambda: _intruder(bus, tmp, "api", password="wrong-password")}[how]()
    try:
        assert not _wait(lambda: list(s.info.peers_zid()), timeout_s=1.5), f"{how}: connected"
        assert alive_nodes(s, bus, timeout_s=0.3) == set()
        with pytest.raises(RecorderError, match="no recorder answered"):
            RecorderClient(s, bus.keys, timeout_s=0.5).status()
    finally:
        s.close()
