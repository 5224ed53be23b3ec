"""The synchronised start of GigE Vision cameras through Aravis: a scheduled action command where the device
takes one, else a software start; what the device lacks is said, never assumed.

:func:`action_support` reads what the device offers: ``ACTION_CMD`` in its GVCP capability register
(bootstrap 0x0934), the ``ActionDeviceKey`` / ``ActionGroupKey`` / ``ActionGroupMask`` features, the
``Action1`` trigger source, and a timestamp latch (``TimestampLatch`` + ``TimestampLatchValue``, or
``GevTimestampControlLatch`` + ``GevTimestampValue``) to read its clock. :func:`scheduled_start` arms the
acquisition start on ``Action1``, starts acquisition (the camera waits), reads the device clock through the
latch, and sends one scheduled action command (:mod:`gaitcap.acquisition.drivers.gvcp_action`) for the
start instant converted to the device clock (device now + (start - host now)): cameras on one PTP clock
start together whatever the clock's epoch (TAI or UTC). Without an acknowledgement the trigger is
switched off, so the camera free-runs from then (a software start), and the status says why.

Tested against the protocol simulator only where it lacks all of it (``arv-fake-gv-camera-0.8``: no
``ACTION_CMD`` capability, no action features, no latch; it ignores the command); the armed path needs a
camera that has them (docs/lab-setup.md, what only hardware can show).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import Any

from gaitcap.acquisition.drivers.gvcp_action import (
    CAPABILITY_ACTION,
    GVCP_CAPABILITY_REGISTER,
    ActionCommand,
    send_action,
)

log = logging.getLogger(__name__)

ACTION_FEATURES = ("ActionDeviceKey", "ActionGroupKey", "ActionGroupMask")
ACTION_TRIGGER = "Action1"
LATCHES = (("TimestampLatch", "TimestampLatchValue"), ("GevTimestampControlLatch", "GevTimestampValue"))
DEVICE_KEY, GROUP_KEY, GROUP_MASK = 0x6761_6974, 0x0000_0001, 0x0000_0001  # gaitcap's rig: one group
MIN_LEAD_S = 0.05  # a start closer than this (or past) is scheduled this far ahead


@dataclass(frozen=True)
class ActionSupport:
    """What the device offers for a scheduled start (each part read from the device)."""

    gvcp_action: bool
    action_features: bool
    action_trigger: bool
    latch: tuple[str, str] | None

    @property
    def usable(self) -> bool:
        return self.gvcp_action and self.action_features and self.action_trigger and self.latch is not None

    def describe(self) -> str:
        """The status line: supported, or what the device lacks."""
        if self.usable:
            return "supported by the device: the start is a scheduled action command on its clock"
        lacks = [text for ok, text in (
            (self.gvcp_action, "ACTION_CMD in its GVCP capabilities"),
            (self.action_features, "the ActionDeviceKey/ActionGroupKey/ActionGroupMask features"),
            (self.action_trigger, f"the {ACTION_TRIGGER} trigger source"),
            (self.latch is not None, "a timestamp latch to read its clock")) if not ok]
        return "not supported by the device (it lacks " + ", ".join(lacks) + ")"


def action_support(cam: Any) -> ActionSupport:
    """What Aravis camera ``cam`` offers (its GVCP capability register, features and trigger sources)."""
    try:
        capability = int(cam.get_device().read_register(GVCP_CAPABILITY_REGISTER))
    except Exception:  # noqa: BLE001  (a device without the register takes no action command)
        capability = 0
    latch = next((pair for pair in LATCHES if all(cam.is_feature_available(f) for f in pair)), None)
    return ActionSupport(gvcp_action=bool(capability & CAPABILITY_ACTION),
                         action_features=all(cam.is_feature_available(f) for f in ACTION_FEATURES),
                         action_trigger=ACTION_TRIGGER in (cam.dup_available_trigger_sources() or []),
                         latch=latch)


def _arm(cam: Any) -> None:
    dev = cam.get_device()
    dev.set_integer_feature_value("ActionDeviceKey", DEVICE_KEY)
    dev.set_integer_feature_value("ActionGroupKey", GROUP_KEY)
    dev.set_integer_feature_value("ActionGroupMask", GROUP_MASK)
    dev.set_string_feature_value("TriggerSelector", "AcquisitionStart")
    dev.set_string_feature_value("TriggerMode", "On")
    dev.set_string_feature_value("TriggerSource", ACTION_TRIGGER)


def _device_now_ticks(cam: Any, latch: tuple[str, str]) -> int:
    dev = cam.get_device()
    dev.execute_command(latch[0])
    return int(dev.get_integer_feature_value(latch[1]))


def scheduled_start(cam: Any, address: str, at_ns: int, support: ActionSupport) -> str:
    """Start ``cam`` (at ``address``) at host time ``at_ns`` by a scheduled action command; returns the
    status's ``start_sync`` line. Falls back to a software start (trigger off: free run from now) when the
    command is not acknowledged."""
    _arm(cam)
    cam.start_acquisition()
    ticks_per_s = float(cam.get_device().get_timestamp_tick_frequency() or 1e9)
    host_now = time.time_ns()
    device_now = _device_now_ticks(cam, support.latch)
    lead_s = max(MIN_LEAD_S, (at_ns - host_now) / 1e9)
    command = ActionCommand(DEVICE_KEY, GROUP_KEY, GROUP_MASK, device_now + int(lead_s * ticks_per_s))
    ack = send_action(command, [address])[address]
    if ack is not None and ack.ok:
        return (f"scheduled action command: acquisition starts at device time {command.action_time_ticks} "
                f"({lead_s:.3f} s after it was sent; acknowledged)")
    cam.get_device().set_string_feature_value("TriggerMode", "Off")
    why = "not acknowledged" if ack is None else f"refused with GVCP status 0x{ack.status:04x}"
    log.warning("camera at %s: scheduled action command %s: software start", address, why)
    return f"software start: the scheduled action command was {why}"
