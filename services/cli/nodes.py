"""``gaitcap node camera|detector|recorder``: run one bus node as a process (until Ctrl-C / SIGTERM).

Every node takes ``--bus FILE`` (JSON5 bus file, else ``$GAITCAP_BUS``, else the local default on
127.0.0.1:7447+) and ``--node NAME`` (its name in the bus file: the endpoint it listens on and the
liveliness token ``<prefix>/alive/<node>``).
"""

from __future__ import annotations

import dataclasses
import logging
import threading
from pathlib import Path

import typer
from gaitcap.services.catalog.paths import DEFAULT_DATA_DIR
from gaitcap.services.cli._common import key_values, stop_on_signals, user_errors

log = logging.getLogger("gaitcap.node")

node_app = typer.Typer(help="Run a bus node (camera, detector, recorder) as a process.", no_args_is_help=True)

BUS_OPT = typer.Option(None, "--bus", help="Bus file (JSON5); default $GAITCAP_BUS or local 127.0.0.1:7447+.")


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise ValueError(f"--size: expected WIDTHxHEIGHT, got {text!r}") from None
    return w, h


def _sim_options(preset: str, seconds: float, cameras: int, people: int, seed: int, fps: float):
    from gaitcap.acquisition.drivers.simulated import SimTrialSpec

    return SimTrialSpec(preset=preset, seconds=seconds, cameras=cameras, people=people, seed=seed, fps=fps)


@node_app.command("camera")
def camera_cmd(
    node: str = typer.Option("camera-0", "--node", help="Node name (bus file entry)."),
    bus: Path | None = BUS_OPT,
    source: str = typer.Option("simulated", "--source", help="simulated | video | flir | aravis"),
    cameras: str | None = typer.Option(None, "--cameras", help="Comma-separated camera names (default: all)."),
    size: str = typer.Option("640x480", "--size", help="Image size WIDTHxHEIGHT px (simulated)."),
    fps: float = typer.Option(30.0, "--fps", help="Frame rate, frames/s."),
    jpeg_quality: int = typer.Option(90, "--jpeg-quality"),
    start_at_ns: int | None = typer.Option(None, "--start-at-ns", help="Synchronised start, wall clock ns."),
    cycle_epoch_ns: int | None = typer.Option(
        None, "--cycle-epoch-ns", help="Simulated: start on the walk's grid EPOCH + k x its length (wall clock ns), "
        "joining the current play-through, so several camera processes share one frame count."),
    sim_preset: str = typer.Option("paper", "--sim-preset", help="Synthetic noise preset."),
    sim_seconds: float = typer.Option(6.0, "--sim-seconds", help="Synthetic trial length, s (>= 5)."),
    sim_cameras: int = typer.Option(10, "--sim-cameras"),
    sim_people: int = typer.Option(1, "--sim-people"),
    sim_seed: int = typer.Option(0, "--sim-seed"),
    sim_loop: bool = typer.Option(False, "--sim-loop", help="Simulated: play the walk again and again with no "
                                  "pause, frame ids counting on (a rig that runs all day)."),
    drop: list[str] = typer.Option([], "--drop", help="Simulated fault CAM:ID,ID (dropped frame ids)."),
    stop: list[str] = typer.Option([], "--stop", help="Simulated fault CAM:ID (camera dies after ID)."),
    frames: int | None = typer.Option(None, "--frames", help="Play at most this many frames (simulated, aravis)."),
    board_clip: str = typer.Option("short", "--board-clip", help="Board shown on Calibrate (simulated): short (6 s) | full (60 s)."),
    videos: list[Path] = typer.Option([], "--video", help="Video file(s) (source video); camera = file stem."),
    webcam: list[int] = typer.Option([], "--webcam", help="Webcam index (source video)."),
    serials: str | None = typer.Option(None, "--serials", help="FLIR serial numbers, comma-separated."),
    exposure_us: float = typer.Option(15000.0, "--exposure-us", help="FLIR fixed exposure, us."),
    pixel_format: str = typer.Option("BayerRG8", "--pixel-format"),
    packet_size: int = typer.Option(9000, "--packet-size", help="FLIR GigE packet size (jumbo 9000)."),
    packet_delay: int = typer.Option(4000, "--packet-delay", help="FLIR GigE inter-packet delay (ticks)."),
    trigger: str = typer.Option("Action0", "--trigger", help="FLIR start: Action0 (scheduled action) or Line0.."),
    devices: str | None = typer.Option(None, "--devices", help="Aravis: GigE Vision serials, device ids or IP "
                                       "addresses, comma-separated (names from --cameras)."),
    packet_delay_ns: int = typer.Option(0, "--packet-delay-ns", help="Aravis GigE inter-packet delay, ns."),
    gain_db: float | None = typer.Option(None, "--gain-db", help="Aravis fixed gain, dB (default: the camera's)."),
) -> None:
    """Publish the frames and status of one host's cameras."""
    from gaitcap.acquisition.drivers.sources import AravisSource, FlirSource, SimulatedSource, VideoSource
    from gaitcap.services.bus.session import default_bus_config, open_session
    from gaitcap.services.nodes.camera import CameraNode
    from gaitcap.services.nodes.sim_scene import attach_board_scene

    with user_errors():
        names = [c for c in (cameras or "").split(",") if c] or None
        builders = {
            "simulated": lambda: SimulatedSource(
                spec=_sim_options(sim_preset, sim_seconds, sim_cameras, sim_people, sim_seed, fps),
                cameras=names, size_px=_size(size), fps=fps, drops=tuple(drop), stops=tuple(stop),
                max_frames=frames, loop=sim_loop),
            "video": lambda: VideoSource(files=tuple(str(v) for v in videos), webcams=tuple(webcam), fps=fps),
            "flir": lambda: FlirSource(serials=tuple(s for s in (serials or "").split(",") if s),
                                       names=tuple(names or ()), fps=fps, exposure_us=exposure_us,
                                       pixel_format=pixel_format, packet_size=packet_size,
                                       packet_delay=packet_delay, trigger_source=trigger),
            "aravis": lambda: AravisSource(devices=tuple(d for d in (devices or "").split(",") if d),
                                           names=tuple(names or ()), fps=fps, exposure_us=exposure_us,
                                           pixel_format=pixel_format, packet_size_bytes=packet_size,
                                           packet_delay_ns=packet_delay_ns, gain_db=gain_db, max_frames=frames),
        }
        if source not in builders:
            raise ValueError(f"--source: {source!r} is not one of {sorted(builders)}")
        from gaitcap.simulator.board_scene import board_scene_config

        board_scene_config(board_clip)  # a wrong name fails here, cleanly
        drivers = builders[source]().build()
        if cycle_epoch_ns is not None:
            start_at_ns = _join_walk(source, drivers, cycle_epoch_ns)
        cfg = default_bus_config(bus)
        session = open_session(cfg, node)
    stopper = stop_on_signals()
    cam_node = CameraNode(session, cfg, node, drivers, jpeg_quality=jpeg_quality)
    scene_sub = attach_board_scene(session, cfg, drivers, board_clip)
    threading.Thread(target=lambda: (stopper.wait(), cam_node.stop()), daemon=True).start()
    try:
        published = cam_node.run(start_at_ns)
        typer.echo(f"camera node {node}: published {published}")
    finally:
        cam_node.close()
        if scene_sub is not None:
            scene_sub.undeclare()
        session.close()


def _join_walk(source: str, drivers, epoch_ns: int) -> int:
    """Set the simulated cameras to join the walk where it is; returns the start (wall clock ns) of its
    current play-through on its grid from ``epoch_ns`` (looping cameras: ``epoch_ns`` itself, their frame
    ids counting on from it)."""
    import time

    from gaitcap.acquisition.drivers.simulated import cycle_start_ns

    if source != "simulated":
        raise ValueError(f"--cycle-epoch-ns: only for --source simulated, not {source}")
    for d in drivers:
        d.join_running = True  # the walk may have been playing for a while: join it where it is
    first = drivers[0]
    if first.loop:
        return epoch_ns
    return cycle_start_ns(epoch_ns=epoch_ns, cycle_ns=first.num_frames() * first.settings.period_ns,
                          now_ns=time.time_ns())


@node_app.command("detector")
def detector_cmd(
    node: str = typer.Option("detector", "--node"),
    bus: Path | None = BUS_OPT,
    detector: str = typer.Option("simulated", "--detector", help="Detector kind (gaitcap.acquisition.detectors)."),
    param: list[str] = typer.Option([], "--param", help="Detector config field KEY=VALUE (JSON value)."),
    workers: int | None = typer.Option(
        None, "--workers", help="Detector worker processes on this host, each with its own model (default: one per "
        "CPU core); a camera's frames always go to the same worker."),
    cameras: str | None = typer.Option(None, "--cameras", help="Detect only these cameras (comma-separated)."),
    shard: str | None = typer.Option(
        None, "--shard", help="K/N: detect only the cameras of shard K of N (several detector nodes share a rig)."),
    batch: int = typer.Option(4, "--batch", help="Frames a worker takes at once (batched by models that take a batch)."),
    max_lag_s: float = typer.Option(
        2.0, "--max-lag-s", help="A frame queued longer than this when a worker is free is skipped (counted; completed after "
        "Stop): live keypoints stay fresh, s."),
    sim_preset: str = typer.Option("paper", "--sim-preset", help="Synthetic noise preset."),
    sim_seconds: float = typer.Option(6.0, "--sim-seconds", help="Synthetic trial length, s (>= 5)."),
    sim_cameras: int = typer.Option(10, "--sim-cameras"),
    sim_people: int = typer.Option(1, "--sim-people"),
    sim_seed: int = typer.Option(0, "--sim-seed"),
    fps: float = typer.Option(30.0, "--fps", help="Frame rate of the simulated trial."),
) -> None:
    """Detect 2D keypoints on every frame of the bus and publish them."""
    import gaitcap.acquisition.detectors  # noqa: F401  (registers the detector kinds)
    from gaitcap.acquisition.detectors.base import config_class
    from gaitcap.acquisition.detectors.pool import DetectorPool, default_workers, shared_cores
    from gaitcap.services.bus.session import default_bus_config, open_session
    from gaitcap.services.nodes.board_watch import BoardWatcher
    from gaitcap.services.nodes.detector import CameraSelection, DetectorNode

    with user_errors():
        params = key_values(param)
        cls = config_class(detector)
        if "trial" in {f.name for f in dataclasses.fields(cls)}:  # simulated: the synthetic trial
            params["trial"] = _sim_options(sim_preset, sim_seconds, sim_cameras, sim_people, sim_seed, fps).make()
        config = cls(**params)
        selection = CameraSelection.parse(cameras, shard)
        cfg = default_bus_config(bus)
        size = workers or default_workers()
        pool = DetectorPool.of_processes(shared_cores(config, size).build, size, max_batch=batch, max_age_s=max_lag_s)
        session = open_session(cfg, node)
    stopper = stop_on_signals()
    det_node = DetectorNode(session, cfg, node, pool, cameras=selection)
    watcher = BoardWatcher(session, cfg, cameras=selection)  # looks for the board while a board recording runs
    typer.echo(f"detector node {node} ready on {cfg.prefix} ({detector}, {pool.skeleton}, {pool.size} workers)")
    stopper.wait()
    watcher.close()
    det_node.close()
    session.close()
    typer.echo(f"detector node {node}: {det_node.detected} frames, {det_node.skipped} skipped, {det_node.lost} lost, "
               f"{det_node.failed} failed")


@node_app.command("recorder")
def recorder_cmd(
    node: str = typer.Option("recorder", "--node"),
    bus: Path | None = BUS_OPT,
    compression: str = typer.Option("lz4", "--compression", help="lz4 | none"),
    chunk_mb: float = typer.Option(4.0, "--chunk-mb", help="Image chunk size, MB."),
    flush_s: float = typer.Option(1.0, "--flush-s", help="At most this much data is lost on a crash, s."),
    data_dir: Path = typer.Option(DEFAULT_DATA_DIR, "--data-dir", envvar="GAITCAP_DATA_DIR",
                                  help="The only folder the recorder writes into (trial paths must be inside)."),
    queue_max: int = typer.Option(1000, "--queue-max", help="Messages queued for the disk at most."),
    queue_block_s: float = typer.Option(0.25, "--queue-block-s", help="Wait this long for room, then drop, s."),
) -> None:
    """Record trials (started and stopped over the bus) into MCAP files inside the data folder."""
    from gaitcap.acquisition.recording.writer import WriterSettings
    from gaitcap.services.bus.session import default_bus_config, open_session
    from gaitcap.services.nodes.recorder import QueuePolicy, RecorderNode

    with user_errors():
        settings = WriterSettings(compression=compression, chunk_size_bytes=int(chunk_mb * 2**20),
                                  flush_interval_s=flush_s)
        policy = QueuePolicy(max_items=queue_max, block_s=queue_block_s)
        cfg = default_bus_config(bus)
        session = open_session(cfg, node)
    stopper = stop_on_signals()
    rec = RecorderNode(session, cfg, node, data_root=data_dir, settings=settings, policy=policy)
    typer.echo(f"recorder node {node} ready on {cfg.prefix}")
    stopper.wait()
    rec.close()
    session.close()


def register(app: typer.Typer) -> None:
    app.add_typer(node_app, name="node")
