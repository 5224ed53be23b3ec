"""A fake ``PySpin`` module: records every call made on it and yields Bayer frames after the action command.

Configure with :func:`reset` (cameras by serial, frames per camera, dropped / incomplete frame ids, PTP
lock delay, a camera that stalls). Every call is appended to :data:`calls` as a tuple
``(owner, node_or_method, value)``; e.g. ``("cam:1001", "ExposureTime", 15000.0)``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

calls: list[tuple[str, str, object]] = []


class SpinnakerException(Exception):
    pass


_ENUMS = {
    "AcquisitionMode": ["Continuous", "SingleFrame"],
    "PixelFormat": ["BayerRG8", "BayerBG8", "BayerGR8", "BayerGB8", "Mono8", "RGB8", "BGR8"],
    "ExposureAuto": ["Off", "Continuous"],
    "TriggerMode": ["Off", "On"],
    "TriggerSelector": ["AcquisitionStart", "FrameStart"],
    "TriggerSource": ["Action0", "Line0", "Software"],
    "StreamBufferHandlingMode": ["OldestFirst", "NewestOnly"],
    "GevIEEE1588Status": ["Initializing", "Faulty", "Disabled", "Listening", "PreMaster", "Master", "Passive",
                          "Uncalibrated", "Slave"],
}
for _prefix, _values in _ENUMS.items():
    for _v in _values:
        globals()[f"{_prefix}_{_v}"] = f"{_prefix}_{_v}"


@dataclass
class Behaviour:
    frames: int = 10
    period_ns: int = 33_333_333
    drop_ids: set[int] = field(default_factory=set)
    incomplete_ids: set[int] = field(default_factory=set)
    jump_at: int | None = None  # frame index whose timestamp jumps by 1 s
    ptp_polls_until_lock: int = 2
    color_bgr: tuple[int, int, int] = (0, 0, 255)  # the scene: pure red
    size: tuple[int, int] = (8, 6)  # width, height
    first_camera_frame_id: int = 100


_behaviour: dict[str, Behaviour] = {}
_clock_offset_ns = 5_000_000_000_000


def reset(serials: dict[str, Behaviour]) -> None:
    """New fake world: cameras with these serials and behaviours; clears :data:`calls`."""
    calls.clear()
    _behaviour.clear()
    _behaviour.update(serials)
    System._instance = None


def ptp_now_ns() -> int:
    return time.time_ns() + _clock_offset_ns


class Node:
    def __init__(self, owner: str, name: str, value=None, getter=None):
        self.owner, self.name, self.value, self._getter = owner, name, value, getter

    def SetValue(self, value):
        calls.append((self.owner, self.name, value))
        self.value = value

    def GetValue(self):
        return self._getter() if self._getter else self.value

    def Execute(self):
        calls.append((self.owner, self.name, "Execute"))
        if self.name == "TimestampLatch":
            self.value = ptp_now_ns()


class _NodeHolder:
    def __init__(self, owner: str):
        object.__setattr__(self, "_owner", owner)
        object.__setattr__(self, "_nodes", {})

    def __getattr__(self, name: str) -> Node:
        if name.startswith("_"):
            raise AttributeError(name)
        nodes = self._nodes
        if name not in nodes:
            nodes[name] = Node(self._owner, name)
        return nodes[name]


def _mosaic_rggb(bgr: np.ndarray) -> np.ndarray:
    """(H, W, 3) BGR -> (H, W) RGGB Bayer raw."""
    raw = np.zeros(bgr.shape[:2], np.uint8)
    raw[0::2, 0::2] = bgr[0::2, 0::2, 2]
    raw[0::2, 1::2] = bgr[0::2, 1::2, 1]
    raw[1::2, 0::2] = bgr[1::2, 0::2, 1]
    raw[1::2, 1::2] = bgr[1::2, 1::2, 0]
    return raw


class FakeImage:
    def __init__(self, owner: str, frame_id: int, ts: int, raw: np.ndarray, incomplete: bool):
        self.owner, self.frame_id, self.ts, self.raw, self.incomplete = owner, frame_id, ts, raw, incomplete
        self.released = False

    def IsIncomplete(self):
        return self.incomplete

    def GetFrameID(self):
        return self.frame_id

    def GetTimeStamp(self):
        return self.ts

    def GetNDArray(self):
        return self.raw

    def Release(self):
        self.released = True
        calls.append((self.owner, "Image.Release", self.frame_id))


class FakeCamera(_NodeHolder):
    def __init__(self, serial: str):
        super().__init__(f"cam:{serial}")
        object.__setattr__(self, "serial", serial)
        object.__setattr__(self, "TLDevice", _NodeHolder(f"cam:{serial}:TLDevice"))
        object.__setattr__(self, "TLStream", _NodeHolder(f"cam:{serial}:TLStream"))
        self.TLDevice.DeviceSerialNumber.value = serial
        object.__setattr__(self, "_polls", 0)
        object.__setattr__(self, "_armed", False)
        object.__setattr__(self, "_start_ns", None)
        object.__setattr__(self, "_next", 0)
        self._nodes["GevIEEE1588Status"] = Node(self._owner, "GevIEEE1588Status", getter=self._ptp_status)
        self._nodes["TimestampLatchValue"] = Node(self._owner, "TimestampLatchValue",
                                                  getter=lambda: self.TimestampLatch.value)

    @property
    def behaviour(self) -> Behaviour:
        return _behaviour[self.serial]

    def _ptp_status(self):
        object.__setattr__(self, "_polls", self._polls + 1)
        if not self._nodes.get("GevIEEE1588") or not self._nodes["GevIEEE1588"].value:
            return GevIEEE1588Status_Disabled  # noqa: F821  (defined from _ENUMS)
        if self._polls <= self.behaviour.ptp_polls_until_lock:
            return GevIEEE1588Status_Listening  # noqa: F821
        serials = sorted(_behaviour)
        return GevIEEE1588Status_Master if self.serial == serials[0] else GevIEEE1588Status_Slave  # noqa: F821

    def Init(self):
        calls.append((self._owner, "Init", None))

    def DeInit(self):
        calls.append((self._owner, "DeInit", None))

    def BeginAcquisition(self):
        calls.append((self._owner, "BeginAcquisition", None))
        object.__setattr__(self, "_armed", True)

    def EndAcquisition(self):
        calls.append((self._owner, "EndAcquisition", None))
        object.__setattr__(self, "_armed", False)

    def action(self, device_key: int, group_key: int, group_mask: int, at_ns: int) -> None:
        """An action command arrived: start if armed, keys match and the trigger is Action0."""
        if not self._armed or self.TriggerSource.value != TriggerSource_Action0:  # noqa: F821
            return
        if (self.ActionDeviceKey.value, self.ActionGroupKey.value) != (device_key, group_key):
            return
        if not self.ActionGroupMask.value & group_mask:
            return
        object.__setattr__(self, "_start_ns", at_ns)

    def GetNextImage(self, timeout_ms=1000):
        b = self.behaviour
        i = self._next
        if self._start_ns is None or not self._armed or i >= b.frames:
            time.sleep(min(timeout_ms, 5) / 1000)
            raise SpinnakerException(f"Spinnaker: GetNextImage timed out after {timeout_ms} ms [-1011]")
        object.__setattr__(self, "_next", i + 1)
        if i in b.drop_ids:
            return self.GetNextImage(timeout_ms)
        ts = self._start_ns + i * b.period_ns + (1_000_000_000 if b.jump_at is not None and i >= b.jump_at else 0)
        w, h = b.size
        raw = _mosaic_rggb(np.tile(np.array(b.color_bgr, np.uint8), (h, w, 1)))
        return FakeImage(self._owner, b.first_camera_frame_id + i, ts, raw, i in b.incomplete_ids)


class CameraList:
    def __init__(self, cams: list[FakeCamera]):
        self.cams = cams

    def GetSize(self):
        return len(self.cams)

    def GetByIndex(self, i):
        return self.cams[i]

    def GetBySerial(self, serial):
        for c in self.cams:
            if c.serial == serial:
                return c
        raise SpinnakerException(f"no camera with serial {serial}")

    def Clear(self):
        calls.append(("system", "CameraList.Clear", None))


class FakeInterface:
    def __init__(self, system: System, index: int):
        self.TLInterface = _NodeHolder(f"iface:{index}")
        self._system = system
        tl = self.TLInterface
        tl._nodes["ActionCommand"] = _ActionNode(f"iface:{index}", tl, system)


class _ActionNode(Node):
    def __init__(self, owner, tl, system):
        super().__init__(owner, "ActionCommand")
        self._tl, self._system = tl, system

    def Execute(self):
        calls.append((self.owner, "ActionCommand", "Execute"))
        tl = self._tl
        for cam in self._system.cams:
            cam.action(tl.GevActionDeviceKey.value, tl.GevActionGroupKey.value, tl.GevActionGroupMask.value,
                       tl.GevActionTime.value)


class InterfaceList(list):
    def GetSize(self):
        return len(self)

    def GetByIndex(self, i):
        return self[i]

    def Clear(self):
        calls.append(("system", "InterfaceList.Clear", None))


class System:
    _instance: System | None = None

    def __init__(self):
        self.cams = [FakeCamera(s) for s in _behaviour]

    @classmethod
    def GetInstance(cls):
        calls.append(("system", "GetInstance", None))
        if cls._instance is None:
            cls._instance = cls()
        return cls._instance

    def GetCameras(self):
        return CameraList(self.cams)

    def GetInterfaces(self):
        return InterfaceList([FakeInterface(self, 0)])

    def ReleaseInstance(self):
        calls.append(("system", "ReleaseInstance", None))
