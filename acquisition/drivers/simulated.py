"""Simulated cameras: the synthetic world rendered from each rig camera.

Each :class:`SimulatedCamera` plays one camera of a synthetic trial (``gaitcap.simulator``): it
renders frame ``i`` at the chosen resolution and frame rate and stamps it with the camera's clock:

    timestamp_ns = start_ns + i * period_ns + clock_offsets_ns[c] + jitter_ns[c, i]

A realtime camera with :attr:`SimulatedCamera.join_running` set and started at a time already past joins
a rig that has been running since then: frame ids still count from that start, and the frames due before
it was started are not delivered (several camera processes, or one restarted, keep one frame count;
:func:`cycle_start_ns`). Without it every frame from the start is delivered, late ones at once.

A camera with ``loop`` set plays the walk again and again with no pause (a live rig that runs all day):
frame ids go on counting (as a camera's counter does) and frame id ``i`` shows the walk's frame
``i mod n`` (``n``: :meth:`SimulatedCamera.walk_frames`); the simulated detector looks keypoints up the same way.

Optional faults: dropped frame ids (the id is skipped, as a real camera's counter would) and a camera that
stops after a given frame id (the iterator ends and the status says ``error``). The ground truth of a
frame stays with the simulator: :meth:`SimulatedCamera.trial_index` maps a frame id to the trial's frame.
"""

from __future__ import annotations

import itertools
import logging
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from gaitcap.acquisition.drivers.base import CaptureSettings, DriverStatus, Frame, is_ptp_jump, wait_until_ns

log = logging.getLogger(__name__)

RenderFn = Callable[[Any, int, int, tuple[int, int]], np.ndarray]


@dataclass(frozen=True)
class SimulatedFaults:
    """Faults of one simulated camera.

    Attributes:
        drop_frame_ids: frame ids that are never delivered (counted as drops).
        stop_after_frame_id: the camera dies after delivering this frame id (None: never).
    """

    drop_frame_ids: frozenset[int] = frozenset()
    stop_after_frame_id: int | None = None


def _default_render(trial: Any, camera_index: int, frame_index: int, size_px: tuple[int, int]) -> np.ndarray:
    from gaitcap.simulator.render import render_frame

    return render_frame(trial, camera_index, frame_index, size_px=size_px)


def trial_fps(trial: Any) -> float:
    """The synthetic trial's frame rate in frames/s (from its ``times_s``)."""
    times = np.asarray(trial.times_s, dtype=np.float64)
    if times.size < 2:
        raise ValueError("trial: needs at least 2 frames to know its frame rate")
    return float(1.0 / np.median(np.diff(times)))


class SimulatedCamera:
    """One camera of a synthetic trial, behind the :class:`~gaitcap.acquisition.drivers.base.CameraDriver` protocol.

    Args:
        trial: a synthetic trial (``.rig``, ``.times_s`` (T,), ``.clock_offsets_ns`` (C,),
            ``.jitter_ns`` (C, T)).
        camera_index: which rig camera this is.
        realtime: pace frames on the wall clock (live use); False delivers as fast as possible.
        faults: optional dropped frames / stop.
        render: ``render(trial, camera_index, frame_index, size_px) -> (H, W, 3) uint8``.
        max_frames: deliver at most this many frame ids (None: the walk once, or without end with ``loop``).
        loop: play the walk again and again, frame ids counting on (see the module docstring).
    """

    def __init__(
        self,
        trial: Any,
        camera_index: int,
        *,
        realtime: bool = True,
        faults: SimulatedFaults = SimulatedFaults(),
        render: RenderFn = _default_render,
        max_frames: int | None = None,
        loop: bool = False,
    ) -> None:
        num = len(trial.rig)
        if not 0 <= camera_index < num:
            raise ValueError(f"camera_index: {camera_index} outside the rig's {num} cameras")
        self.trial = trial
        self.camera_index = camera_index
        self.name = trial.rig[camera_index].name
        self.realtime = realtime
        self.faults = faults
        self._render = render
        self.max_frames = max_frames
        self.loop = loop
        self._settings = CaptureSettings(fps=trial_fps(trial), exposure_us=None)
        self._status = DriverStatus(camera=self.name)
        self._start_ns: int | None = None
        self._first_id = 0  # the first frame id delivered (> 0: joined a rig running since _start_ns)
        self.join_running = False  # a start already past: skip the frames due before now (see the module)
        self._stopped = False
        # (SceneSwitch, BoardScene) of gaitcap.simulator.board_scene: show a calibration board instead
        self.scene: tuple[Any, Any] | None = None

    def open(self) -> None:
        self._status.state = "open"

    def configure(self, settings: CaptureSettings) -> None:
        if self._status.state == "closed":
            raise ValueError(f"camera {self.name}: configure() before open()")
        self._settings = settings
        self._status.state = "configured"

    @property
    def settings(self) -> CaptureSettings:
        return self._settings

    @property
    def size_px(self) -> tuple[int, int]:
        return self._settings.size_px or tuple(int(v) for v in self.trial.rig[self.camera_index].size_px)

    def walk_frames(self) -> int:
        """Frame ids in one play-through of the walk at the configured frame rate."""
        duration_s = float(self.trial.times_s[-1] - self.trial.times_s[0]) + 1.0 / trial_fps(self.trial)
        return int(np.floor(duration_s * self._settings.fps + 1e-9))

    def num_frames(self) -> int:
        """How many frame ids are played: the walk once (or ``max_frames``; with ``loop``, ``max_frames`` or
        one play-through: the period of its frame grid)."""
        n = self.walk_frames()
        if self.loop and self.max_frames is not None:
            return self.max_frames
        return n if self.max_frames is None else min(n, self.max_frames)

    def _frame_ids(self) -> Iterator[int]:
        if self.loop and self.max_frames is None:
            return itertools.count(self._first_id)
        return iter(range(self._first_id, self.num_frames()))

    def start(self, at_ns: int | None = None) -> None:
        if self._status.state not in ("configured", "open"):
            raise ValueError(f"camera {self.name}: start() in state {self._status.state}")
        now = time.time_ns()
        self._start_ns = now if at_ns is None else int(at_ns)
        late_ns = now - self._start_ns if self.realtime and self.join_running else 0
        self._first_id = max(0, late_ns // self._settings.period_ns)  # frames due before now are not delivered
        self._stopped = False
        self._status.state = "running"
        joined_ns = self._start_ns + self._first_id * self._settings.period_ns
        self._status.started_wall_s = joined_ns / 1e9 if self.realtime else time.time()  # the rate counts from here

    def trial_index(self, frame_id: int) -> int:
        """The index into the synthetic trial (its ``times_s``, ground truth) of frame ``frame_id`` (with
        ``loop``: of its place in the current play-through)."""
        if self.loop:
            frame_id %= self.walk_frames()
        t0 = float(self.trial.times_s[0])
        t = t0 + frame_id / self._settings.fps
        idx = int(np.searchsorted(self.trial.times_s, t - 1e-9))
        return min(idx, len(self.trial.times_s) - 1)

    def timestamp_ns(self, frame_id: int) -> int:
        """The camera timestamp of ``frame_id`` (ns): start + i * period + clock offset + jitter."""
        idx = self.trial_index(frame_id)
        c = self.camera_index
        offset = int(np.asarray(self.trial.clock_offsets_ns)[c])
        jitter = int(np.asarray(self.trial.jitter_ns)[c, idx])
        return int(self._start_ns + frame_id * self._settings.period_ns + offset + jitter)

    def frames(self) -> Iterator[Frame]:
        if self._start_ns is None:
            raise ValueError(f"camera {self.name}: frames() before start()")
        period = self._settings.period_ns
        last_ts: int | None = None
        last_id: int | None = None
        for frame_id in self._frame_ids():
            if self._stopped:
                break
            if frame_id in self.faults.drop_frame_ids:
                continue
            ts = self.timestamp_ns(frame_id)
            if self.realtime:
                wait_until_ns(ts)
            idx = self.trial_index(frame_id)
            image = self._image(frame_id, idx)
            jump = last_ts is not None and is_ptp_jump(ts - last_ts, period * (frame_id - last_id))
            frame = Frame(
                camera=self.name,
                image=image,
                timestamp_ns=ts,
                frame_id=frame_id,
                ptp_jump=jump,
            )
            self._status.count(frame)
            last_ts, last_id = ts, frame_id
            yield frame
            if self.faults.stop_after_frame_id is not None and frame_id >= self.faults.stop_after_frame_id:
                self._status.state = "error"
                self._status.error = f"camera {self.name} stopped delivering frames after frame {frame_id}"
                log.warning(self._status.error)
                return
        if self._status.state == "running":
            self._status.state = "stopped"

    def _image(self, frame_id: int, idx: int) -> np.ndarray:
        """The walker's frame ``idx``, or the board when :attr:`scene` says so for ``frame_id``."""
        if self.scene is not None:
            switch, board = self.scene
            k = switch.board_index(frame_id, camera_start_ns=self._start_ns, period_ns=self._settings.period_ns)
            if k is not None:
                return board.render(self.name, k, self.size_px)
        return self._render(self.trial, self.camera_index, idx, self.size_px)

    def stop(self) -> None:
        self._stopped = True
        if self._status.state == "running":
            self._status.state = "stopped"

    def status(self) -> DriverStatus:
        return self._status


def simulated_rig(
    trial: Any,
    *,
    size_px: tuple[int, int] = (640, 480),
    fps: float | None = None,
    realtime: bool = True,
    faults: dict[str, SimulatedFaults] | None = None,
    cameras: list[str] | None = None,
    render: RenderFn = _default_render,
    max_frames: int | None = None,
    loop: bool = False,
) -> list[SimulatedCamera]:
    """Open and configure one :class:`SimulatedCamera` per rig camera (or per name in ``cameras``)."""
    faults = faults or {}
    names = trial.rig.names if cameras is None else cameras
    unknown = sorted((set(faults) | set(names)) - set(trial.rig.names))
    if unknown:
        raise ValueError(f"cameras {unknown} are not in the synthetic rig {trial.rig.names}")
    drivers = []
    for name in names:
        cam = SimulatedCamera(
            trial,
            trial.rig.index_of([name])[0],
            realtime=realtime,
            faults=faults.get(name, SimulatedFaults()),
            render=render,
            max_frames=max_frames,
            loop=loop,
        )
        cam.open()
        cam.configure(CaptureSettings(fps=fps or trial_fps(trial), exposure_us=None, size_px=size_px))
        drivers.append(cam)
    return drivers


def cycle_start_ns(*, epoch_ns: int, cycle_ns: int, now_ns: int) -> int:
    """The start (wall clock ns) of the simulated world's current play-through on the grid
    ``epoch_ns + k * cycle_ns`` (k >= 0; ``cycle_ns``: the walk's length): the latest at or before
    ``now_ns``, or ``epoch_ns`` while that is ahead. Camera processes that start (or restart) at different
    times thus share one synchronised start and frame count."""
    if cycle_ns <= 0:
        raise ValueError(f"cycle_ns: the simulated walk's length must be > 0 ns, got {cycle_ns}")
    if now_ns <= epoch_ns:
        return int(epoch_ns)
    return int(epoch_ns + (now_ns - epoch_ns) // cycle_ns * cycle_ns)


@dataclass(frozen=True)
class SimTrialSpec:
    """How to rebuild the same synthetic trial in several processes (camera and detector nodes).

    Attributes mirror ``gaitcap.simulator.make_trial(preset, seconds, cameras, people, seed, fps)``.
    """

    preset: str = "paper"
    seconds: float = 6.0
    cameras: int = 10
    people: int = 1
    seed: int = 0
    fps: float = 30.0

    def make(self) -> Any:
        from gaitcap.simulator import make_trial

        return make_trial(self.preset, seconds=self.seconds, cameras=self.cameras, people=self.people,
                          seed=self.seed, fps=self.fps)


def parse_faults(drops: list[str], stops: list[str]) -> dict[str, SimulatedFaults]:
    """CLI fault specs -> faults: ``CAM:ID,ID,...`` drops those frame ids; ``CAM:ID`` stops after ID."""
    dropped: dict[str, set[int]] = {}
    stopped: dict[str, int] = {}
    for spec in drops:
        cam, _, ids = spec.partition(":")
        try:
            dropped.setdefault(cam, set()).update(int(i) for i in ids.split(",") if i)
        except ValueError:
            raise ValueError(f"--drop: expected CAMERA:ID,ID,..., got {spec!r}") from None
    for spec in stops:
        cam, _, fid = spec.partition(":")
        try:
            stopped[cam] = int(fid)
        except ValueError:
            raise ValueError(f"--stop: expected CAMERA:FRAME_ID, got {spec!r}") from None
    return {cam: SimulatedFaults(frozenset(dropped.get(cam, ())), stopped.get(cam))
            for cam in set(dropped) | set(stopped)}
