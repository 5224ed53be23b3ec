import os
import resource
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from gaitcap.acquisition.drivers.simulated import parse_faults, simulated_rig
from gaitcap.acquisition.recording.reader import is_complete, iter_frames, read_metadata, read_status
from gaitcap.acquisition.recording.recovery import recover
from gaitcap.services.bus.control import RecorderClient, RecorderError, subscribe_events
from gaitcap.services.bus.session import BusConfig, alive_nodes, open_session
from gaitcap.services.nodes.camera import CameraNode
from gaitcap.services.nodes.recorder import RecorderNode
from gaitcap.simulator import make_trial

from .conftest import noise_render, wait_for

ROOT = Path(__file__).resolve().parents[3]


def free_bus(names, prefix="gaitcap/rt"):
    return BusConfig.free_local(names, prefix=prefix)


@pytest.fixture(scope="module")
def trial():
    return make_trial("paper", seconds=5.0, cameras=4, people=1, seed=1, fps=30.0)


def _camera_node(session, bus, trial, *, frames, realtime, faults=None, size=(32, 24), node="camera-0"):
    drivers = simulated_rig(trial, size_px=size, realtime=realtime, render=noise_render, max_frames=frames,
                            faults=parse_faults(*(faults or ([], []))))
    return CameraNode(session, bus, node, drivers, status_interval_s=0.2)


def test_trial_with_a_stopped_camera_and_drops_is_recorded_and_reported(tmp_path, trial):
    bus = free_bus(["recorder", "camera-0"])
    srec, scam = open_session(bus, "recorder"), open_session(bus, "camera-0")
    rec = RecorderNode(srec, bus, data_root=tmp_path)
    events = []
    ev_sub = subscribe_events(scam, bus.keys, events.append)
    try:
        wait_for(lambda: "recorder" in alive_nodes(scam, bus), what="recorder alive")
        client = RecorderClient(scam, bus.keys)
        reply = client.start(trial_id="t1", path=str(tmp_path / "t1.mcap"), metadata={"patient": "p"},
                             cameras=trial.rig.names)
        assert reply.ok and reply.path == str(tmp_path / "t1.mcap")
        assert client.status().recording is True
        node = _camera_node(scam, bus, trial, frames=30, realtime=False,
                            faults=(["cam02:3,4"], ["cam03:9"]))
        node.run(start_at_ns=time.time_ns())
        wait_for(lambda: rec.status().queued == 0, what="recorder queue drained")
        time.sleep(0.3)
        out = client.stop("t1")
        summary = out.summary
        cams = summary["cameras"]
        assert cams["cam01"]["frames"] == 30 and cams["cam01"]["gaps"] == []
        assert cams["cam02"]["gaps"] == [[3, 4]] and cams["cam02"]["missing_frames"] == 2
        assert cams["cam03"]["stopped_early"] and cams["cam03"]["gaps"] == [[10, 29]]
        assert cams["cam03"]["health"] == "error"
        assert summary["cameras_stopped_early"] == ["cam03"] and summary["frames"] == 30 + 28 + 10 + 30
        path = Path(out.path)
        assert is_complete(path) and read_metadata(path) == {"patient": "p", "trial_id": "t1"}
        assert len(list(iter_frames(path, "cam03"))) == 10
        assert read_status(path)["cam03"][-1]["health"] == "error"
        wait_for(lambda: [e.event for e in events] == ["started", "stopped"], what="events")
        assert events[1].summary["cameras"]["cam03"]["gaps"] == [[10, 29]]
        node.close()
    finally:
        ev_sub.undeclare()
        rec.close()
        srec.close()
        scam.close()


def test_refusals_are_acknowledged_with_a_reason(tmp_path):
    bus = free_bus(["recorder"])
    srec, sc = open_session(bus, "recorder"), open_session(bus)
    rec = RecorderNode(srec, bus, data_root=tmp_path)
    try:
        wait_for(lambda: "recorder" in alive_nodes(sc, bus), what="recorder alive")
        client = RecorderClient(sc, bus.keys, timeout_s=5)
        with pytest.raises(RecorderError, match="missing path"):
            client.start(trial_id="a", path="")
        (tmp_path / "exists.mcap").write_bytes(b"x")
        with pytest.raises(RecorderError, match="already exists"):
            client.start(trial_id="a", path=str(tmp_path / "exists.mcap"))
        client.start(trial_id="a", path=str(tmp_path / "a.mcap"))
        with pytest.raises(RecorderError, match="already recording trial a"):
            client.start(trial_id="b", path=str(tmp_path / "b.mcap"))
        with pytest.raises(RecorderError, match="not recording it"):
            client.stop("b")
        assert client.stop("a").summary["frames"] == 0
        assert is_complete(tmp_path / "a.mcap")
    finally:
        rec.close()
        srec.close()
        sc.close()
    lonely = open_session(free_bus(["x"]))
    try:
        with pytest.raises(RecorderError, match="no recorder answered"):
            RecorderClient(lonely, bus.keys, timeout_s=0.3).stop("a")
    finally:
        lonely.close()


def _recorder_process(bus_file: Path, *, fsize_limit: int | None = None, flush_s: float = 0.2):
    def limit():
        if fsize_limit is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (fsize_limit, fsize_limit))

    env = dict(os.environ, GAITCAP_BUS=str(bus_file), GAITCAP_DATA_DIR=str(bus_file.parent), PYTHONPATH=str(ROOT))
    cmd = [sys.executable, "-c", "from gaitcap.services.cli import main; main()", "node", "recorder",
           "--node", "recorder", "--flush-s", str(flush_s), "--chunk-mb", "0.1"]
    return subprocess.Popen(cmd, env=env, cwd=str(ROOT), preexec_fn=limit,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def _bus_file(tmp_path, bus):
    import json

    f = tmp_path / "bus.json"
    f.write_text(json.dumps(bus.to_dict()))
    return f


def test_disk_full_stops_cleanly_with_an_error(tmp_path, trial):
    bus = free_bus(["recorder", "camera-0"])
    proc = _recorder_process(_bus_file(tmp_path, bus), fsize_limit=400_000)
    s = open_session(bus, "camera-0")
    events = []
    ev_sub = subscribe_events(s, bus.keys, events.append)
    try:
        wait_for(lambda: "recorder" in alive_nodes(s, bus), timeout_s=60, what="recorder process alive")
        client = RecorderClient(s, bus.keys)
        client.start(trial_id="full", path=str(tmp_path / "full.mcap"))
        node = _camera_node(s, bus, trial, frames=60, realtime=False, size=(96, 72))  # ~25 kB frames
        node.run(start_at_ns=time.time_ns())
        wait_for(lambda: any(e.event == "error" for e in events), what="error event")
        err = next(e for e in events if e.event == "error")
        assert "write failed" in err.error and "File too large" in err.error
        with pytest.raises(RecorderError, match="write failed"):
            client.stop("full")
        assert proc.poll() is None, "the recorder must survive a full disk"
        part = tmp_path / "full.mcap.part"
        assert part.exists() and not (tmp_path / "full.mcap").exists()
        report = recover(part, tmp_path / "rescued.mcap")
        assert report.messages and sum(report.messages.values()) > 5
        node.close()
    finally:
        ev_sub.undeclare()
        s.close()
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=20)


def test_sigkilled_recorder_leaves_a_recoverable_file(tmp_path, trial):
    bus = free_bus(["recorder", "camera-0"])
    proc = _recorder_process(_bus_file(tmp_path, bus), flush_s=0.2)
    s = open_session(bus, "camera-0")
    try:
        wait_for(lambda: "recorder" in alive_nodes(s, bus), timeout_s=60, what="recorder process alive")
        RecorderClient(s, bus.keys).start(trial_id="k", path=str(tmp_path / "k.mcap"))
        node = _camera_node(s, bus, trial, frames=150, realtime=True, size=(64, 48))
        runner = threading.Thread(target=node.run, kwargs={"start_at_ns": time.time_ns()})
        runner.start()
        time.sleep(2.0)
        sent = dict(node.published)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        node.stop()
        runner.join()
        node.close()
        report = recover(tmp_path / "k.mcap")
        assert not report.was_complete and report.corrupt_chunks == 0
        for cam, n in sent.items():
            frames = [f.frame_id for f in iter_frames(report.output, cam)]
            # everything older than the flush interval (+ margin) is on disk, in order, decodable
            assert len(frames) >= n - 15, (cam, len(frames), n)
            assert frames == list(range(len(frames)))
        assert next(iter_frames(report.output)).image().shape == (48, 64, 3)
    finally:
        s.close()
        if proc.poll() is None:
            proc.kill()
