"""The whole gaitcap stack as real processes on one machine, on embedded defaults.

Simulated camera rig (``camera_nodes`` camera processes, each rendering a share of the cameras),
simulated detector, recorder, worker(s) and the API, all Zenoh peers on 127.0.0.1 with explicit endpoints
(a bus file written into the data folder), the catalog in ``<data_dir>/catalog.sqlite``, each process's
log in ``<data_dir>/logs/``. :class:`Stack` starts them, waits until cameras, keypoints, worker and API
are ready, restarts a process that dies (a supervising thread), and stops everything on exit.

The bus is secured even on loopback (mutual TLS with a CA of the stack's own, a password per node and
access control by role, :mod:`gaitcap.services.bus.security`): the keys and passwords are made at the first
start into ``<data_dir>/bus-keys`` (folder 0700, private files 0600) and kept. A plain TCP bus, open to
any local process, only with ``plain_bus`` (``gaitcap demo --plain-bus``), and said at start.
Each child gets only the environment it needs (:mod:`gaitcap.services.ops.child_env`).

The simulated world is a ``sim_seconds`` long walk in the paper's room; the camera processes play it
again and again with no pause (``--sim-loop``), frame ids counting on. Several camera processes count
from the stack's start (``--cycle-epoch-ns``), so they, also a restarted one joining mid-walk, keep one
synchronised frame count.

With ``gige`` the cameras are fake GigE Vision cameras instead (``arv-fake-gv-camera-0.8``, one process
each, speaking the real protocol: :class:`gaitcap.simulator.fake_gige.FakeGigELab` behind a veth link with
jumbo frames, in a network namespace of their own, so it needs root), driven by the camera processes
through the Aravis driver (``--source aravis``) from this host like a real rig. Their frame ids count
frame periods from the stack's start on the cameras' clock (``--start-at-ns``; the fake cameras' clock is
the host's), one count for every camera process and a restarted one. The fake cameras film a test
pattern with nobody in it: the trial's keypoints come from the simulated detector (by camera and frame
id, the simulated walk), so this exercises acquisition over the GigE Vision protocol, the bus,
recording and processing, not detection; the page's Calibrate (the simulated board) has no board to see.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import sys
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from gaitcap.acquisition.fileio import atomic_write_text
from gaitcap.services.catalog.paths import DEMO_DATA_DIR, catalog_url
from gaitcap.services.ops.child_env import child_environment, held_secrets
from gaitcap.services.ops.supervisor import ProcessSpec, Supervisor

log = logging.getLogger(__name__)
CLI = (sys.executable, "-c", "from gaitcap.services.cli import main; main()")
#: libpq's settings a worker and the API get from the stack's environment: the password file and TLS files.
LIBPQ_SETTINGS = frozenset({"PGPASSFILE", "PGSSLMODE", "PGSSLROOTCERT", "PGSSLCERT", "PGSSLKEY", "PGSSLCRL"})
STACK_CLIENT = "stack"  # the bus identity of the stack's own checks (listens nowhere; role client)


@dataclass(frozen=True)
class StackConfig:
    """Where and how the stack runs. Ports: API ``port``; bus nodes ``bus_base_port`` and up. ``token`` is
    the password of the stack's ``demo`` account (every role), made in ``data_dir/accounts.json``.
    ``camera_nodes``: processes the simulated cameras are dealt to (one holds 10 x 30 fps at 240x180 px on
    a loaded 2-core machine; more give it headroom). ``plain_bus``: a bus without TLS, passwords or access
    control (any local process can use it; default: secured, see the module docstring). ``extra_env``: variables set in every child (on top of
    what each needs: :mod:`gaitcap.services.ops.child_env`)."""

    data_dir: Path = DEMO_DATA_DIR
    token: str = ""
    host: str = "127.0.0.1"
    port: int = 8000
    bus_base_port: int = 7447
    cameras: int = 10
    camera_nodes: int = 1
    size: str = "240x180"
    fps: float = 30.0
    sim_preset: str = "paper"
    sim_seconds: float = 300.0
    sim_people: int = 1
    seed: int = 0
    workers: int = 1
    lease_s: float = 10.0
    refine: bool = True
    camera_nice: int = 5
    board_clip: str = "short"
    catalog_url: str = ""
    room: str = ""  # the capture room this stack runs ('' the default room; several rooms share a central catalog)
    extra_env: dict[str, str] = field(default_factory=dict)
    plain_bus: bool = False  # plain TCP bus, no authentication: only when asked for by name
    gige: bool = False  # fake GigE Vision cameras through the Aravis driver (module docstring), not simulated ones

    def __post_init__(self) -> None:
        if len(self.token) < 12:
            raise ValueError("token: the demo account's password needs at least 12 characters")
        if not 2 <= self.cameras <= 64:
            raise ValueError(f"cameras: need 2..64 cameras, got {self.cameras}")
        if not 1 <= self.camera_nodes <= self.cameras:
            raise ValueError(f"camera_nodes: need 1..{self.cameras} camera processes, got {self.camera_nodes}")
        if not 1 <= self.workers <= 8:
            raise ValueError(f"workers: need 1..8 workers, got {self.workers}")
        from gaitcap.simulator.board_scene import board_scene_config

        board_scene_config(self.board_clip)
        if self.sim_people not in (1, 2, 3):
            raise ValueError(f"sim_people: the simulated world has 1, 2 or 3 people, got {self.sim_people}")
        if self.sim_seconds < 5:
            raise ValueError(f"sim_seconds: the simulated walk must last >= 5 s, got {self.sim_seconds}")
        from gaitcap.services.catalog.rooms import check_room

        check_room(self.room)

    @property
    def catalog(self) -> str:
        return catalog_url(Path(self.data_dir).resolve(), self.catalog_url)

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}"

    def worker_names(self) -> list[str]:
        return [f"worker-{i}" for i in range(self.workers)]

    def camera_node_names(self) -> list[str]:
        return [f"camera-{i}" for i in range(self.camera_nodes)]

    def camera_shares(self) -> dict[str, list[str]]:
        """Camera process -> the simulated cameras it runs (cam01.. dealt in turn)."""
        from gaitcap.simulator.room import build_rig

        names = build_rig(self.cameras).names
        return {node: list(names[i :: self.camera_nodes]) for i, node in enumerate(self.camera_node_names())}


def bus_keys_dir(cfg: StackConfig) -> Path:
    """Where the stack's bus keys and passwords are made at its first start (and kept)."""
    return Path(cfg.data_dir).resolve() / "bus-keys"


def bus_config(cfg: StackConfig):
    """The stack's bus: one loopback port per node from ``bus_base_port``; secured (``tls/`` endpoints,
    keys in :func:`bus_keys_dir`, the stack's own client :data:`STACK_CLIENT`) unless ``plain_bus``."""
    from gaitcap.services.bus.security import BusSecurity
    from gaitcap.services.bus.session import BusConfig

    nodes = ("recorder", "detector", "api", *cfg.camera_node_names(), *cfg.worker_names())
    plain = BusConfig.local(cfg.bus_base_port, nodes=nodes)
    if cfg.plain_bus:
        return plain
    return BusConfig({n: "tls/" + e.split("/", 1)[1] for n, e in plain.nodes.items()}, prefix=plain.prefix,
                     security=BusSecurity(bus_keys_dir(cfg), clients=(STACK_CLIENT,)))


def make_stack_bus_keys(cfg: StackConfig) -> list[str]:
    """The secured bus's CA, certificates and passwords in :func:`bus_keys_dir` (the missing ones; existing
    files are kept); returns the identities made now (none for a plain bus)."""
    from gaitcap.services.bus.certs import make_bus_keys

    bus = bus_config(cfg)
    if bus.security is None:
        return []
    return make_bus_keys({n: bus.nodes.get(n) for n in bus.identities}, bus.security.keys_dir)


def _sim_args(cfg: StackConfig) -> list[str]:
    return ["--sim-preset", cfg.sim_preset, "--sim-seconds", str(cfg.sim_seconds), "--sim-cameras",
            str(cfg.cameras), "--sim-seed", str(cfg.seed), "--fps", str(cfg.fps), "--sim-people", str(cfg.sim_people)]


def _camera_args(cfg: StackConfig) -> list[str]:
    return [*_sim_args(cfg), "--sim-loop"]  # the walk starts over with no pause


GIGE_CAMERA_ARGS = ("--pixel-format", "BayerRG8", "--packet-size", "9000", "--exposure-us", "8000")


def gige_unavailable() -> str:
    """Why the stack cannot run on fake GigE Vision cameras here ("" when it can): Aravis, the fake camera
    program or network namespaces missing."""
    from gaitcap.acquisition.drivers.aravis import AravisMissing, import_aravis
    from gaitcap.simulator.fake_gige import fake_camera_binary, namespace_unavailable

    try:
        import_aravis()
        fake_camera_binary()
    except (AravisMissing, ValueError) as exc:
        return str(exc)
    reason = namespace_unavailable()
    return f"the fake cameras' network namespace: {reason}" if reason else ""


def _camera_argv(cfg: StackConfig, node: str, cameras: list[str], *, epoch_ns: int | None,
                 devices: Mapping[str, str] | None) -> tuple[str, ...]:
    """A camera process's command: simulated cameras, or with ``cfg.gige`` the fake GigE Vision cameras at
    ``devices`` (camera name -> address) counting frames from ``epoch_ns``."""
    head, names = (*CLI, "node", "camera", "--node", node), ("--cameras", ",".join(cameras))
    if not cfg.gige:
        epoch = ["--cycle-epoch-ns", str(int(epoch_ns))] if epoch_ns is not None and cfg.camera_nodes > 1 else []
        return (*head, "--source", "simulated", *names, "--size", cfg.size, "--board-clip", cfg.board_clip,
                *_camera_args(cfg), *epoch)
    missing = [c for c in cameras if c not in (devices or {})]
    if missing:
        raise ValueError(f"gige: no GigE Vision device address for cameras {missing} (Stack.start starts the "
                         "fake cameras and passes them)")
    start = ["--start-at-ns", str(int(epoch_ns))] if epoch_ns is not None else []
    return (*head, "--source", "aravis", *names, "--devices", ",".join(devices[c] for c in cameras),
            "--fps", str(cfg.fps), *GIGE_CAMERA_ARGS, *start)


def bus_file(cfg: StackConfig) -> Path:
    """The stack's bus file (every node reads it through ``GAITCAP_BUS``)."""
    return Path(cfg.data_dir).resolve() / "bus.json"


def stack_set_env(cfg: StackConfig, role: str, parent_env: Mapping[str, str] | None = None) -> dict[str, str]:
    """What the stack sets in the environment of a child of ``role``: the bus file for every node; the
    data folder for the recorder, the worker and the API (the recorder writes only inside it); the
    catalog (given here, never on a command line, which any user of the host can list) and libpq's settings
    (its password file, TLS: :data:`LIBPQ_SETTINGS`) for the worker and the API; the room and the frame-rate
    criteria for the API."""
    env = {"GAITCAP_BUS": str(bus_file(cfg))}
    if role in ("recorder", "worker", "api"):
        env["GAITCAP_DATA_DIR"] = str(Path(cfg.data_dir).resolve())
    if role in ("worker", "api"):
        env["GAITCAP_CATALOG"] = cfg.catalog
        env.update({k: v for k, v in (os.environ if parent_env is None else parent_env).items()
                    if k in LIBPQ_SETTINGS})
    if role == "api":
        from gaitcap.services.processing.quality import QualityCriteria

        env["GAITCAP_ROOM"] = cfg.room
        env["GAITCAP_MIN_FPS"] = str(QualityCriteria().min_fps_at(cfg.fps))  # the criteria scale with fps
    return {**env, **cfg.extra_env}


def _spec(cfg: StackConfig, parent_env, role: str, name: str, argv: tuple[str, ...], **kw) -> ProcessSpec:
    return ProcessSpec(name, argv, env=child_environment(role, parent_env, stack_set_env(cfg, role, parent_env)), **kw)


def process_specs(cfg: StackConfig, *, epoch_ns: int | None = None, parent_env=None,
                  devices: Mapping[str, str] | None = None) -> list[ProcessSpec]:
    """The processes of the stack, in start order; ``epoch_ns``: the camera processes' synchronised start
    (wall clock ns; None: each its own); ``parent_env``: the environment the children's are drawn from
    (default ``os.environ``; each child gets only what it needs, :func:`child_environment`); ``devices``:
    with ``cfg.gige``, each camera's GigE Vision device address."""
    parent_env = os.environ if parent_env is None else parent_env
    data = str(Path(cfg.data_dir).resolve())
    specs = [
        _spec(cfg, parent_env, "recorder", "recorder", (*CLI, "node", "recorder", "--node", "recorder"),
              ready_text="ready"),
        _spec(cfg, parent_env, "detector", "detector", (*CLI, "node", "detector", "--node", "detector",
                                                        "--detector", "simulated", *_sim_args(cfg),
                                                        "--workers", "1")),  # a look-up: one process keeps up
    ]
    # several camera processes share one frame count from the stack's start (one simulated process: its own
    # start, and a restarted one starts its counter again, as camera hardware does)
    for node, cameras in cfg.camera_shares().items():
        # The simulated cameras stand in for camera hardware: rendering them must not slow processing.
        specs.append(_spec(cfg, parent_env, "camera", node,
                           _camera_argv(cfg, node, cameras, epoch_ns=epoch_ns, devices=devices), nice=cfg.camera_nice))
    for name in cfg.worker_names():
        argv = [*CLI, "worker", "--node", name, "--id", name, "--data-dir", data, "--lease", str(cfg.lease_s)]
        specs.append(_spec(cfg, parent_env, "worker", name, tuple(argv + ([] if cfg.refine else ["--no-refine"])),
                           ready_text="ready"))
    specs.append(_spec(cfg, parent_env, "api", "api", (
        *CLI, "serve", "--node", "api", "--data-dir", data, "--host", cfg.host, "--port",
        str(cfg.port), "--sim-scene"), ready_text="Uvicorn running"))
    return specs


def register_calibration(cfg: StackConfig) -> str:
    """Store the simulated rig's calibration in the catalog (the API hands it to the recorder)."""
    from gaitcap.acquisition.drivers.simulated import SimTrialSpec
    from gaitcap.reconstruction.calibration_io import rig_to_toml_text
    from gaitcap.services import catalog as cat

    rig = SimTrialSpec(preset=cfg.sim_preset, seconds=5.0, cameras=cfg.cameras, seed=cfg.seed, fps=cfg.fps).make().rig
    toml = rig_to_toml_text(rig)
    db = cat.open_catalog(cfg.catalog)
    try:
        if cfg.room:
            cat.register_room(db, cfg.room)  # (its API registers it too, with its host)
        latest = cat.latest_calibration(db, cfg.room)
        if latest is not None and latest[1] == toml:
            return latest[0]
        return cat.add_calibration(db, toml=toml, source=f"simulated rig ({cfg.cameras} cameras, seed {cfg.seed})",
                                   room=cfg.room)
    finally:
        db.close()


class Stack:
    """Start with :meth:`start` (or as a context manager); :meth:`supervise` until a stop event."""

    def __init__(self, cfg: StackConfig) -> None:
        self.cfg = cfg
        self.data_dir = Path(cfg.data_dir).resolve()
        self.bus = bus_config(cfg)
        self.bus_file = bus_file(cfg)
        self.epoch_ns = time.time_ns()  # the camera processes' synchronised start
        self.supervisor = Supervisor(self.data_dir / "logs", base_env={})  # each spec: its whole environment
        self.gige_lab = None  # the fake GigE Vision cameras (cfg.gige), started by start()
        self.devices: dict[str, str] | None = None  # camera name -> GigE Vision device address (cfg.gige)
        self._stop_supervising = threading.Event()
        self._supervising: threading.Thread | None = None

    @property
    def page_url(self) -> str:
        return f"{self.cfg.url}/"

    def __enter__(self) -> Stack:
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

    def start(self, *, timeout_s: float = 180.0) -> None:
        self.data_dir.mkdir(parents=True, exist_ok=True)
        made = make_stack_bus_keys(self.cfg)
        if made:
            log.info("bus keys made in %s for %s", bus_keys_dir(self.cfg), ", ".join(made))
        if self.cfg.plain_bus:
            log.warning("bus: plain TCP on loopback (asked for): no authentication, any local process can use it")
        atomic_write_text(self.bus_file, json.dumps(self.bus.to_dict(), indent=2))
        register_calibration(self.cfg)
        from gaitcap.services.access.accounts import AccountStore
        from gaitcap.services.access.client import DEMO_ROLES, DEMO_USER

        AccountStore(self.data_dir / "accounts.json").set(DEMO_USER, password=self.cfg.token, roles=DEMO_ROLES)
        held = held_secrets("camera", os.environ)
        if held:  # names only, never values
            log.info("not passed to the camera, detector and recorder processes: %s", ", ".join(held))
        try:
            if self.cfg.gige:
                self._start_gige_cameras()
            for spec in process_specs(self.cfg, epoch_ns=self.epoch_ns, devices=self.devices):
                self.supervisor.start(spec)
            self.wait_ready(timeout_s=timeout_s)
        except BaseException:
            self.stop()
            raise
        self._supervising = threading.Thread(target=self._supervise, name="stack-supervisor", daemon=True)
        self._supervising.start()

    def _start_gige_cameras(self) -> None:
        """The fake GigE Vision cameras behind their link (ValueError saying why where they cannot run)."""
        from gaitcap.simulator.fake_gige import FakeGigELab
        from gaitcap.simulator.room import build_rig

        reason = gige_unavailable()
        if reason:
            raise ValueError(f"gige: fake GigE Vision cameras cannot run here: {reason}")
        log_dir = self.data_dir / "logs"
        log_dir.mkdir(parents=True, exist_ok=True)
        self.gige_lab = FakeGigELab(self.cfg.cameras, host_link=True, log_dir=log_dir)
        self.gige_lab.start()
        self.devices = dict(zip(build_rig(self.cfg.cameras).names, self.gige_lab.addresses, strict=True))
        log.info("fake GigE Vision cameras %s behind a link in namespace %s (this host: %s)",
                 ", ".join(f"{c} at {a}" for c, a in self.devices.items()), self.gige_lab.namespace,
                 self.gige_lab.host_address)

    def wait_ready(self, *, timeout_s: float) -> None:
        """Until every process logged ready, the API answers, all cameras are seen and keypoints flow."""
        deadline = time.monotonic() + timeout_s
        for spec in process_specs(self.cfg, devices=self.devices):
            if spec.ready_text:
                self.supervisor.wait_ready(spec.name, max(1.0, deadline - time.monotonic()))
        self._wait_cameras(deadline)
        self._wait_keypoints(deadline)
        log.info("stack ready at %s", self.cfg.url)

    @contextlib.contextmanager
    def client(self, timeout_s: float = 30.0):
        """``with stack.client() as c``: an ``httpx.Client`` on the API, signed in as the demo account."""
        import httpx
        from gaitcap.services.access.client import DEMO_USER, sign_in

        with httpx.Client(base_url=self.cfg.url, timeout=timeout_s) as client:
            deadline = time.monotonic() + 60  # the API may be restarting (supervisor back-off, start-up)
            while True:
                try:
                    client.get("/health").raise_for_status()
                    break
                except httpx.HTTPError:
                    if time.monotonic() > deadline:
                        raise
                    time.sleep(0.2)
            yield sign_in(client, DEMO_USER, self.cfg.token)

    def _wait_cameras(self, deadline: float) -> None:
        import httpx

        seen = []
        while time.monotonic() < deadline:
            try:
                with self.client(timeout_s=5) as client:
                    seen = [c for c in client.get("/cameras").json()
                            if c["healthy"] or c["status"].startswith("slow")]  # delivering (a slow one: at Start)
            except httpx.HTTPError:
                seen = []
            if len(seen) >= self.cfg.cameras:
                return
            self.supervisor.poll()
            time.sleep(0.5)
        raise RuntimeError(f"only {len(seen)} of {self.cfg.cameras} cameras delivering; logs in {self.supervisor.log_dir}")

    def bus_session(self):
        """A bus session of the stack's own client identity (close it after use)."""
        from gaitcap.services.bus.session import open_session

        return open_session(self.bus, None if self.bus.security is None else STACK_CLIENT)

    def _wait_keypoints(self, deadline: float) -> None:
        got = threading.Event()
        session = self.bus_session()
        try:
            sub = session.declare_subscriber(self.bus.keys.keypoints(), lambda _s: got.set())
            while not got.wait(0.5):
                self.supervisor.poll()
                if time.monotonic() > deadline:
                    raise RuntimeError(f"no keypoints from the detector; see {self.supervisor.log_dir}/detector.log")
            sub.undeclare()
        finally:
            session.close()

    def _supervise(self, period_s: float = 0.25) -> None:
        """Restart processes that exit, with back-off, for as long as the stack runs (the supervising
        thread; an unexpected error is logged and supervision goes on)."""
        while not self._stop_supervising.wait(period_s):
            try:
                for name in self.supervisor.poll():
                    log.warning("restarted %s", name)
            except Exception:
                log.exception("supervision: poll failed; trying again")

    def stop(self) -> None:
        self._stop_supervising.set()
        if self._supervising is not None:
            self._supervising.join(10)
        self.supervisor.stop()
        if self.gige_lab is not None:
            self.gige_lab.close()
