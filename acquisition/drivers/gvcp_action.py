"""GigE Vision action commands (GVCP ``ACTION_CMD``, UDP port 3956), sent by gaitcap itself: Aravis 0.8.26
(Debian's) has no action command sender.

An action command carries a device key, a group key and a group mask; a device whose keys match (its
``ActionDeviceKey``, ``ActionGroupKey`` and ``ActionGroupMask`` features) fires the action, at once or,
in a *scheduled* action command, when its clock (the PTP clock of a synchronised rig) reaches the
command's ``action_time``. Set up as the acquisition start trigger (``TriggerSelector=AcquisitionStart``,
``TriggerSource=Action1``), one scheduled command starts every camera at the same instant. A device that
acts answers with ``ACTION_ACK`` when asked (the acknowledge flag); a device that does not take action
commands, or whose keys do not match, stays silent, so silence is reported, never taken as a yes.

Packet (GigE Vision 2.x, big-endian): header ``0x42``, flags (0x01 acknowledge, 0x80 scheduled), command
0x0100, payload length, request id; payload: device key, group key, group mask (32 bits each) and, when
scheduled, the action time (64 bits, device ticks). Answer: status (0 = success), 0x0101, length 0, the
request id.
"""

from __future__ import annotations

import logging
import select
import socket
import struct
import time
from collections.abc import Sequence
from dataclasses import dataclass

log = logging.getLogger(__name__)

GVCP_PORT = 3956
GVCP_KEY = 0x42
ACTION_CMD, ACTION_ACK = 0x0100, 0x0101
FLAG_ACKNOWLEDGE, FLAG_SCHEDULED = 0x01, 0x80
GVCP_CAPABILITY_REGISTER = 0x0934  # bootstrap register: what the device's GVCP takes
CAPABILITY_ACTION = 1 << 6  # ACTION_CMD supported
_U32 = 0xFFFF_FFFF


@dataclass(frozen=True)
class ActionCommand:
    """One action command: keys and mask (32 bits each) and, for a scheduled one, ``action_time_ticks``
    on the devices' clock (ticks of its timestamp; 1 ns on a PTP camera)."""

    device_key: int
    group_key: int
    group_mask: int
    action_time_ticks: int | None = None

    def __post_init__(self) -> None:
        for name in ("device_key", "group_key", "group_mask"):
            value = getattr(self, name)
            if not 0 <= value <= _U32:
                raise ValueError(f"action command: {name} must fit 32 bits, got {value}")
        if self.group_mask == 0:
            raise ValueError("action command: group_mask 0 addresses no group")
        if self.action_time_ticks is not None and not 0 <= self.action_time_ticks < 1 << 64:
            raise ValueError(f"action command: action_time_ticks must fit 64 bits, got {self.action_time_ticks}")

    def packet(self, request_id: int) -> bytes:
        """The GVCP packet with the acknowledge flag (``request_id``: 1..65535)."""
        if not 1 <= request_id <= 0xFFFF:
            raise ValueError(f"action command: request id 1..65535, got {request_id}")
        scheduled = self.action_time_ticks is not None
        payload = struct.pack(">III", self.device_key, self.group_key, self.group_mask)
        if scheduled:
            payload += struct.pack(">Q", self.action_time_ticks)
        flags = FLAG_ACKNOWLEDGE | (FLAG_SCHEDULED if scheduled else 0)
        return struct.pack(">BBHHH", GVCP_KEY, flags, ACTION_CMD, len(payload), request_id) + payload


@dataclass(frozen=True)
class ActionAck:
    """A device's answer: its address and GVCP status (0: the action was taken or scheduled)."""

    address: str
    status: int

    @property
    def ok(self) -> bool:
        return self.status == 0


def parse_ack(data: bytes, request_id: int) -> int | None:
    """The status of an ``ACTION_ACK`` to ``request_id`` (None: not one)."""
    if len(data) < 8:
        return None
    status, answer, _length, ack_id = struct.unpack(">HHHH", data[:8])
    return status if answer == ACTION_ACK and ack_id == request_id else None


def send_action(command: ActionCommand, addresses: Sequence[str], *, timeout_s: float = 0.2, request_id: int = 1,
                port: int = GVCP_PORT) -> dict[str, ActionAck | None]:
    """Send ``command`` to each device at ``addresses`` (unicast, from one socket) and wait up to
    ``timeout_s`` for their acknowledgements; address -> its answer, None where none came (a device that
    does not take action commands, or whose keys do not match)."""
    packet = command.packet(request_id)
    answers: dict[str, ActionAck | None] = dict.fromkeys(addresses)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        for address in addresses:
            sock.sendto(packet, (address, port))
        deadline = time.monotonic() + timeout_s
        while any(a is None for a in answers.values()) and (left := deadline - time.monotonic()) > 0:
            if not select.select([sock], [], [], left)[0]:
                break
            data, (sender, _) = sock.recvfrom(576)
            status = parse_ack(data, request_id)
            if status is not None and sender in answers:
                answers[sender] = ActionAck(sender, status)
    silent = [a for a, ack in answers.items() if ack is None]
    if silent:
        log.info("action command: no acknowledgement from %s within %.0f ms", ", ".join(silent), timeout_s * 1000)
    return answers
