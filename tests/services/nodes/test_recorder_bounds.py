"""The recorder over a real Zenoh bus: paths outside its data folder refused, out-of-range and
malformed messages rejected with a count (never written, never allocating by frame id)."""

import json
import time

import pytest
from gaitcap.acquisition.recording import layout
from gaitcap.acquisition.recording.reader import iter_messages
from gaitcap.services.bus.control import RecorderClient, RecorderError
from gaitcap.services.bus.messages import ImageFrame, Keypoints
from gaitcap.services.bus.session import BusConfig, alive_nodes, open_session
from gaitcap.services.nodes.recorder import KEYPOINT_SLACK_FRAMES, RecorderNode

from .conftest import wait_for

JPEG = bytes.fromhex("ffd8ffe000104a464946") + b"\x00" * 20 + bytes.fromhex("ffd9")


def test_recorder_refuses_outside_paths_and_rejects_out_of_range_messages(tmp_path):
    bus = BusConfig.free_local(["recorder", "camera-0"], prefix="gaitcap/bounds")
    data = tmp_path / "data"
    (data / "t1").mkdir(parents=True)
    srec, s = open_session(bus, "recorder"), open_session(bus, "camera-0")
    rec = RecorderNode(srec, bus, data_root=data)
    try:
        wait_for(lambda: "recorder" in alive_nodes(s, bus), 10.0, "recorder alive")
        client = RecorderClient(s, bus.keys, timeout_s=5)
        for bad in (str(tmp_path / "evil.mcap"), "../evil.mcap"):
            with pytest.raises(RecorderError, match="outside the recorder's data folder"):
                client.start(trial_id="t1", path=bad)
        assert not (tmp_path / "evil.mcap").exists()
        client.start(trial_id="t1", path="t1/recording.mcap")
        for fid in range(100, 105):
            f = ImageFrame.build(JPEG, camera="cam01", timestamp_ns=10**18 + fid, frame_id=fid, sent_ns=time.time_ns())
            s.put(bus.keys.image("cam01"), f.payload, attachment=f.meta.to_bytes())
        people = [[[1.0, 2.0, 0.5]] * 26]
        far = 104 + KEYPOINT_SLACK_FRAMES + 1
        time.sleep(0.3)
        for fid in (102, far, 2**31 - 1):
            s.put(bus.keys.keypoints("cam01"), Keypoints("cam01", fid, 10**18 + fid, "halpe26", people).to_bytes())
        s.put(bus.keys.keypoints("cam01"), json.dumps({"camera": "cam01", "frame_id": 2**40}).encode())
        s.put(bus.keys.keypoints("cam02"), Keypoints("cam01", 103, 1, "halpe26", people).to_bytes())
        wait_for(lambda: rec.status().queued == 0, 10.0, "queue drained")
        time.sleep(0.3)
        summary = client.stop("t1").summary
        assert summary["frames"] == 5 and summary["keypoints"] == 1
        assert summary["rejected"] == 4
        path = data / "t1" / "recording.mcap"
        ids = [json.loads(m.data)["frame_id"] for _t, m in iter_messages(path, layout.is_keypoints_topic)]
        assert ids == [102]
    finally:
        rec.close()
        srec.close()
        s.close()


def test_a_recording_with_a_stray_keypoint_frame_id_is_refused_not_allocated(tmp_path):
    from gaitcap.acquisition.recording.reader import read_keypoints
    from gaitcap.acquisition.recording.writer import TrialWriter, WriterSettings

    writer = TrialWriter(tmp_path / "t.mcap", WriterSettings())
    writer.start(metadata={"trial_id": "t"}, time_ns=1)
    people = [[[1.0, 2.0, 0.5]] * 26]
    for fid in (*range(10), 2**40):  # what an injected message did before the recorder checked frame ids
        writer.add_keypoints("cam01", Keypoints("cam01", min(fid, 2**31 - 1), 10**9 + fid, "halpe26",
                                                people).to_bytes().replace(b"2147483647", str(fid).encode()),
                             timestamp_ns=10**9 + fid, frame_id=fid)
    path = writer.finish({})
    t0 = time.monotonic()
    with pytest.raises(ValueError, match="stray frame id"):
        read_keypoints(path)
    assert time.monotonic() - t0 < 5


def test_keypoints_that_overtake_their_image_are_kept_and_bounded(tmp_path):
    """The detector may answer before the recorder takes the frame: keypoints before any frame are kept
    near the first keypoints' frame id; once frames are recorded, near the frames; far ones are rejected."""
    from gaitcap.services.nodes.recorder import Recording

    rec = Recording("T1", tmp_path / "t.mcap", writer=None, cameras=["cam01"])
    assert rec.accept_keypoints("cam01", 349) and rec.accept_keypoints("cam01", 350)  # before any frame
    assert not rec.accept_keypoints("cam01", 2**40) and rec.rejected == 1
    assert rec.accept_frame("cam01", 351)
    assert rec.accept_keypoints("cam01", 351 + KEYPOINT_SLACK_FRAMES)
    assert not rec.accept_keypoints("cam01", 351 + KEYPOINT_SLACK_FRAMES + 1) and rec.rejected == 2
