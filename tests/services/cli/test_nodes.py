"""End to end: a simulated 10-camera trial through camera, detector and recorder nodes running as
separate processes (`gaitcap node ...`), into an MCAP that opens with the mcap reader and replays."""

import json
import os
import signal
import stat
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from gaitcap.acquisition.recording import layout
from gaitcap.acquisition.recording.reader import iter_frames, read_calibration, read_detections, read_summary
from gaitcap.acquisition.sync import check_sync
from gaitcap.reconstruction.calibration_io import rig_to_toml_text
from gaitcap.services.bus.control import RecorderClient, subscribe_events
from gaitcap.services.bus.session import BusConfig, alive_nodes, declare_alive, open_session, watch_alive
from gaitcap.simulator import make_trial
from mcap.reader import make_reader

ROOT = Path(__file__).resolve().parents[3]
CLI = [sys.executable, "-c", "from gaitcap.services.cli import main; main()"]
SIM = ["--sim-seconds", "5", "--sim-seed", "7"]
FRAMES = 30


def free_bus(names, prefix="gaitcap/e2e"):
    return BusConfig.free_local(names, prefix=prefix)


def wait_for(cond, timeout_s, what):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if cond():
            return
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what}")


@pytest.fixture
def rig(tmp_path):
    bus = free_bus(["recorder", "detector", "camera-0", "camera-1", "replay", "test"])
    bus_file = tmp_path / "bus.json"
    bus_file.write_text(json.dumps(bus.to_dict()))
    env = dict(os.environ, GAITCAP_BUS=str(bus_file), GAITCAP_DATA_DIR=str(tmp_path), PYTHONPATH=str(ROOT))
    procs = {}

    def spawn(name, args):
        procs[name] = subprocess.Popen(CLI + args, env=env, cwd=str(ROOT), stdout=subprocess.PIPE,
                                       stderr=subprocess.STDOUT, text=True)
        return procs[name]

    yield bus, spawn, procs
    for p in procs.values():
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
    for p in procs.values():
        try:
            p.wait(timeout=15)
        except subprocess.TimeoutExpired:
            p.kill()


def test_ten_cameras_through_separate_processes_into_mcap_and_replay(tmp_path, rig):
    bus, spawn, procs = rig
    spawn("recorder", ["node", "recorder", "--node", "recorder", "--flush-s", "0.5"])
    spawn("detector", ["node", "detector", "--node", "detector", *SIM])
    trial = make_trial("paper", seconds=5.0, cameras=10, people=1, seed=7, fps=30.0)
    s = open_session(bus, "test")
    token = declare_alive(s, bus, "test")
    events, changes = [], []
    ev_sub = subscribe_events(s, bus.keys, events.append)
    watcher = watch_alive(s, bus, lambda node, alive: changes.append((node, alive)))
    try:
        wait_for(lambda: {"recorder", "detector"} <= alive_nodes(s, bus), 90, "recorder and detector up")
        client = RecorderClient(s, bus.keys)
        out = tmp_path / "trial.mcap"
        client.start(trial_id="e2e", path=str(out), metadata={"patient": "sim"},
                     calibration_toml=rig_to_toml_text(trial.rig), cameras=trial.rig.names)
        start_ns = time.time_ns() + 4_000_000_000
        halves = [",".join(trial.rig.names[:5]), ",".join(trial.rig.names[5:])]
        for k, cams in enumerate(halves):
            spawn(f"camera-{k}", ["node", "camera", "--node", f"camera-{k}", *SIM, "--cameras", cams,
                                  "--size", "160x120", "--frames", str(FRAMES), "--start-at-ns", str(start_ns)]
                  + (["--stop", "cam08:14"] if k == 1 else []))
        for k in range(2):
            assert procs[f"camera-{k}"].wait(timeout=90) == 0, procs[f"camera-{k}"].stdout.read()
        wait_for(lambda: client.status().queued == 0, 20, "recorder drained")
        time.sleep(1.0)  # last keypoints
        reply = client.stop("e2e")
        summary = reply.summary
        assert reply.ok and summary["frames"] == 9 * FRAMES + 15
        assert summary["cameras_stopped_early"] == ["cam08"]
        assert summary["cameras"]["cam08"]["gaps"] == [[15, FRAMES - 1]]
        assert summary["keypoints"] == summary["frames"]
        assert stat.S_IMODE(out.stat().st_mode) == 0o600  # patient video: owner only (umask 077)
        wait_for(lambda: [e.event for e in events] == ["started", "stopped"], 10, "recorder events")

        # The file opens with the mcap library's own reader and holds what the layout promises.
        with open(out, "rb") as f:
            mc = make_reader(f).get_summary()
        topics = {c.topic for c in mc.channels.values()}
        assert {layout.image_topic(c) for c in trial.rig.names} <= topics
        assert {layout.keypoints_topic(c) for c in trial.rig.names} <= topics
        assert read_summary(out)["cameras"]["cam08"]["stopped_early"] is True
        assert read_calibration(out).names == trial.rig.names

        # Keypoints equal the synthetic world's detections (the simulated detector's noise model).
        det = read_detections(out)
        assert det.shape == (10, FRAMES, 1, 26)
        truth = trial.detections.one_person[:, :FRAMES]
        seen = (truth[..., 2] > 1e-3) & (det.one_person[..., 2] > 0)
        seen[7, 15:] = False
        np.testing.assert_allclose(det.one_person[seen], truth[seen], atol=2e-3)
        assert (det.one_person[7, 15:, :, 2] == 0).all()
        np.testing.assert_allclose(np.diff(det.times_s), 1 / 30, atol=1e-3)

        # The lab's sync criteria on the recorded camera timestamps (frame ids from the synced start).
        stamps, ids = {}, {}
        for fr in iter_frames(out):
            stamps.setdefault(fr.camera, []).append(fr.timestamp_ns)
            ids.setdefault(fr.camera, []).append(fr.frame_id)
        report = check_sync({c: v for c, v in stamps.items() if c != "cam08"}, period_ns=33_333_333,
                            frame_ids={c: v for c, v in ids.items() if c != "cam08"})
        assert report.passed, report.problems

        # A node that dies is seen gone by the others (and it no longer re-detects replayed frames).
        procs["detector"].send_signal(signal.SIGKILL)
        procs["detector"].wait()
        wait_for(lambda: ("detector", False) in changes, 5, "killed detector seen gone")

        # Replay at 4x real time (unpaced, a busy machine's bus may drop frames of a slow subscriber);
        # this test process counts what arrives.
        counts = {"frames": 0, "keypoints": 0}
        lock = threading.Lock()

        def bump(kind):
            with lock:
                counts[kind] += 1

        subs = [s.declare_subscriber(bus.keys.image(), lambda _s: bump("frames")),
                s.declare_subscriber(bus.keys.keypoints(), lambda _s: bump("keypoints"))]
        res = subprocess.run(CLI + ["replay", str(out), "--rate", "4", "--wait-for", "test"],
                             env=dict(os.environ, GAITCAP_BUS=str(tmp_path / "bus.json"), PYTHONPATH=str(ROOT)),
                             cwd=str(ROOT), capture_output=True, text=True, timeout=90)
        assert res.returncode == 0, res.stdout + res.stderr
        assert f"{summary['frames']} frames" in res.stdout
        wait_for(lambda: counts["frames"] == summary["frames"], 10, "replayed frames")
        wait_for(lambda: counts["keypoints"] == summary["keypoints"], 10, "replayed keypoints")
        for sub in subs:
            sub.undeclare()

    finally:
        ev_sub.undeclare()
        watcher.undeclare()
        token.undeclare()
        s.close()


def test_node_commands_report_bad_options(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    res = subprocess.run(CLI + ["node", "camera", "--source", "laser"], env=env, cwd=str(ROOT),
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 2 and "--source" in res.stderr
    res = subprocess.run(CLI + ["node", "camera", "--source", "flir", "--serials", "123"], env=env,
                         cwd=str(ROOT), capture_output=True, text=True, timeout=60)
    assert res.returncode == 2 and "PySpin" in res.stderr
