"""The recorder under faults (real Zenoh on loopback, real MCAP files): a disk slower than the cameras
cannot grow the queue past its bound (frames are dropped and counted), and a recorder started after a
crash finalises the recording the dead one left."""

import threading
import time

import pytest
from gaitcap.acquisition.drivers.simulated import simulated_rig
from gaitcap.acquisition.recording.reader import is_complete, read_summary
from gaitcap.acquisition.recording.writer import TrialWriter, WriterSettings
from gaitcap.services.bus.control import RecorderClient
from gaitcap.services.bus.session import BusConfig, alive_nodes, open_session
from gaitcap.services.nodes.camera import CameraNode
from gaitcap.services.nodes.recorder import QueuePolicy, RecorderNode
from gaitcap.simulator import make_trial

from .conftest import noise_render, wait_for


@pytest.fixture(scope="module")
def trial():
    return make_trial("paper", seconds=4.0, cameras=3, people=1, seed=2, fps=30.0)


def test_a_stalled_disk_keeps_the_queue_bounded_and_counts_dropped_frames(tmp_path, trial):
    bus = BusConfig.free_local(["recorder", "camera-0"], prefix="gaitcap/ri")
    srec, scam = open_session(bus, "recorder"), open_session(bus, "camera-0")
    policy = QueuePolicy(max_items=20, block_s=0.01)
    rec = RecorderNode(srec, bus, data_root=tmp_path, policy=policy)
    gate = threading.Event()
    try:
        wait_for(lambda: "recorder" in alive_nodes(scam, bus), what="recorder alive")
        client = RecorderClient(scam, bus.keys)
        client.start(trial_id="t1", path=str(tmp_path / "t1.mcap"))
        rec._queue.put(("control", gate.wait))  # the disk stalls: the writer thread is stuck on it
        drivers = simulated_rig(trial, size_px=(32, 24), realtime=False, render=noise_render, max_frames=60)
        node = CameraNode(scam, bus, "camera-0", drivers, status_interval_s=0.2)
        node.run(start_at_ns=time.time_ns())
        assert rec.status().queued <= policy.max_items
        gate.set()  # the disk is back
        wait_for(lambda: sum(rec._current.tally(c).frames for c in trial.rig.names)
              + sum(rec._current.dropped.values()) >= 3 * 60 - 5, what="every frame written or counted")
        summary = client.stop("t1").summary
        dropped = summary["dropped_frames"]
        assert sum(dropped.values()) > 0 and set(dropped) <= set(trial.rig.names), dropped
        assert summary["frames"] + sum(dropped.values()) >= 3 * 60 - 5  # kept or counted (status messages too)
        images = summary["dropped_images"]  # the images among the dropped messages, per camera
        assert 0 < sum(images.values()) <= sum(dropped.values()), (images, dropped)
        written = {c: summary["cameras"][c]["frames"] for c in trial.rig.names}
        assert all(written[c] + images.get(c, 0) <= 60 for c in trial.rig.names), (written, images)
        assert is_complete(tmp_path / "t1.mcap")
        node.close()
    finally:
        gate.set()
        rec.close()
        srec.close()
        scam.close()


def test_a_restarted_recorder_finalises_the_recording_a_dead_one_left(tmp_path):
    folder = tmp_path / "trials" / "T1"
    folder.mkdir(parents=True)
    writer = TrialWriter(folder / "recording.mcap", WriterSettings(chunk_size_bytes=1000, flush_interval_s=0.01))
    writer.start(metadata={"trial_id": "T1"}, time_ns=1)
    for i in range(40):
        writer.add_status("cam01", {"camera": "cam01", "frame": i}, time_ns=i + 2)
        writer.flush()
    writer._file.close()  # SIGKILL: the file is never finished
    bus = BusConfig.free_local(["recorder"], prefix="gaitcap/ri2")
    session = open_session(bus, "recorder")
    rec = RecorderNode(session, bus, data_root=tmp_path)
    try:
        assert [r["error"] for r in rec.recovered] == [None]
        final = folder / "recording.mcap"
        assert is_complete(final) and read_summary(final)["recovered"] is True
        assert (folder / "recording.mcap.part.cut").is_file() and not (folder / "recording.mcap.part").exists()
    finally:
        rec.close()
        session.close()


def test_an_unexpected_error_on_one_message_does_not_end_the_writer_thread(tmp_path, trial, monkeypatch):
    """One message raising something other than a bad-message or disk error (a bug) is rejected and logged;
    the writer thread goes on, later frames are written and Stop finishes the file."""
    from gaitcap.services.nodes import recorder as recorder_module

    real, calls = recorder_module.Recording.write_image, []

    def flaky(self, camera, *args):
        calls.append(camera)
        if len(calls) == 5:
            raise RuntimeError("an unforeseen bug")
        return real(self, camera, *args)

    monkeypatch.setattr(recorder_module.Recording, "write_image", flaky)
    bus = BusConfig.free_local(["recorder", "camera-0"], prefix="gaitcap/ri3")
    srec, scam = open_session(bus, "recorder"), open_session(bus, "camera-0")
    rec = RecorderNode(srec, bus, data_root=tmp_path)
    try:
        wait_for(lambda: "recorder" in alive_nodes(scam, bus), what="recorder alive")
        client = RecorderClient(scam, bus.keys)
        client.start(trial_id="t3", path=str(tmp_path / "t3.mcap"))
        drivers = simulated_rig(trial, size_px=(32, 24), realtime=False, render=noise_render, max_frames=20)
        node = CameraNode(scam, bus, "camera-0", drivers, status_interval_s=0.2)
        node.run(start_at_ns=time.time_ns())
        wait_for(lambda: len(calls) >= 3 * 20, what="every frame handed to the writer")
        summary = client.stop("t3").summary
        assert summary["rejected"] == 1 and summary["frames"] == 3 * 20 - 1 and summary["error"] is None
        assert is_complete(tmp_path / "t3.mcap")
        node.close()
    finally:
        rec.close()
        srec.close()
        scam.close()
