"""GigE Vision action commands sent by gaitcap (GVCP ACTION_CMD over UDP): the packet's bytes, answers
collected from a device that acknowledges (a GVCP responder on loopback standing in for a camera that
takes action commands: the hardware edge) and silence from one that does not, and what the real protocol
simulator (``arv-fake-gv-camera-0.8``) does: it takes no action command, the driver reads that from the
device and starts by software, saying why."""

import shutil
import socket
import struct
import threading

import pytest
from gaitcap.acquisition.drivers.gvcp_action import ActionCommand, parse_ack, send_action


def test_the_packet_carries_keys_mask_and_the_scheduled_time():
    now = ActionCommand(device_key=0x11223344, group_key=2, group_mask=0x0F)
    assert now.packet(7) == bytes.fromhex("42 01 0100 000c 0007 11223344 00000002 0000000f".replace(" ", ""))
    later = ActionCommand(device_key=1, group_key=2, group_mask=1, action_time_ticks=0x0102030405060708)
    pkt = later.packet(65535)
    assert pkt[:8] == bytes.fromhex("428101000014ffff") and pkt[-8:] == bytes(range(1, 9))  # scheduled: 20 bytes
    with pytest.raises(ValueError, match="group_mask 0"):
        ActionCommand(device_key=1, group_key=1, group_mask=0)
    with pytest.raises(ValueError, match="device_key must fit 32 bits"):
        ActionCommand(device_key=1 << 32, group_key=1, group_mask=1)


def _device(keys: tuple[int, int, int], got: list) -> tuple[socket.socket, threading.Thread]:
    """A GVCP responder on 127.0.0.1 that acknowledges action commands for ``keys`` (device, group, mask)."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.settimeout(5)

    def serve():
        data, peer = sock.recvfrom(576)
        got.append(data)
        _key, _flags, command, _length, req = struct.unpack(">BBHHH", data[:8])
        device, group, mask = struct.unpack(">III", data[8:20])
        if command == 0x0100 and device == keys[0] and group == keys[1] and mask & keys[2]:
            sock.sendto(struct.pack(">HHHH", 0, 0x0101, 0, req), peer)

    t = threading.Thread(target=serve, daemon=True)
    t.start()
    return sock, t


def test_acknowledgements_are_collected_and_silence_is_reported():
    got: list[bytes] = []
    dev, t = _device((5, 6, 1), got)
    port = dev.getsockname()[1]
    try:
        cmd = ActionCommand(device_key=5, group_key=6, group_mask=1, action_time_ticks=123_456_789)
        answers = send_action(cmd, ["127.0.0.1"], port=port, request_id=42, timeout_s=2.0)
        t.join(5)
        assert answers["127.0.0.1"] is not None and answers["127.0.0.1"].ok, answers
        assert got[0] == cmd.packet(42)
        dev2, t2 = _device((5, 6, 1), got)  # keys that do not match: the device stays silent
        wrong = ActionCommand(device_key=9, group_key=6, group_mask=1)
        assert send_action(wrong, ["127.0.0.1"], port=dev2.getsockname()[1], timeout_s=0.3) == {"127.0.0.1": None}
        t2.join(5)
        dev2.close()
    finally:
        dev.close()
    assert parse_ack(struct.pack(">HHHH", 0x8006, 0x0101, 0, 3), 3) == 0x8006 and parse_ack(b"\x00" * 8, 3) is None


@pytest.mark.skipif(shutil.which("arv-fake-gv-camera-0.8") is None, reason="aravis-tools not installed")
def test_the_fake_camera_takes_no_action_command_and_the_driver_says_so(tmp_path):
    from gaitcap.acquisition.drivers.aravis import AravisCamera, AravisMissing, import_aravis
    from gaitcap.acquisition.drivers.base import CaptureSettings
    from gaitcap.simulator.fake_gige import host_lab

    try:
        import_aravis()
    except AravisMissing as exc:
        pytest.skip(str(exc))
    with host_lab(log_dir=tmp_path):
        cmd = ActionCommand(device_key=1, group_key=1, group_mask=1)
        assert send_action(cmd, ["127.0.0.1"], timeout_s=0.5) == {"127.0.0.1": None}  # measured: no ACTION_ACK
        cam = AravisCamera("127.0.0.1", "cam01")
        cam.open()
        cam.configure(CaptureSettings(fps=30.0, exposure_us=8000.0, pixel_format="Mono8"))
        st = cam.status().to_dict()
        assert st["action_commands"] == (
            "not supported by the device (it lacks ACTION_CMD in its GVCP capabilities, the ActionDeviceKey/"
            "ActionGroupKey/ActionGroupMask features, the Action1 trigger source, a timestamp latch to read its "
            "clock)"), st["action_commands"]
        assert st["start_sync"].startswith("software start (the device takes no scheduled action command"), st
        cam.close()
