"""The recorder over a real Zenoh bus: paths outside its data folder refused, out-of-range and
malformed messages rejected with a count (never written, never allocating by frame id)."""

import json
import time

import numpy as np
import pytest
from gaitcap.acquisition.recording import layout
from gaitcap.acquisition.recording.reader import iter_messages
from gaitcap.reconstruction.ignored_keypoints import IgnoredKeypoints
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


def _write_with_strays(path, ids_of: dict[str, list[int]], *, period_ns: int = 33_333_333):
    """A trial MCAP with keypoints of these frame ids per camera, stamped ``period_ns`` apart by frame id:
    what an injected or corrupt message left before the recorder checked frame ids."""
    from gaitcap.acquisition.recording.writer import TrialWriter, WriterSettings

    writer = TrialWriter(path, WriterSettings())
    writer.start(metadata={"trial_id": "t"}, time_ns=1)
    people = [[[1.0, 2.0, 0.5]] * 26]
    for cam, ids in ids_of.items():
        for fid in ids:
            ts = 10**18 + fid * period_ns if fid < 2**31 else 10**18 + 3 * period_ns  # a stray keeps a sane stamp
            msg = Keypoints(cam, min(fid, 2**31 - 1), ts, "halpe26", people).to_bytes()
            writer.add_keypoints(cam, msg.replace(b"2147483647", str(fid).encode()), timestamp_ns=ts, frame_id=fid)
    return writer.finish({})


def test_a_stray_keypoint_frame_id_is_ignored_and_counted_not_allocated(tmp_path):
    from gaitcap.acquisition.recording.reader import read_keypoints

    path = _write_with_strays(tmp_path / "t.mcap", {"cam01": [*range(10), 2**40], "cam02": list(range(10))})
    t0 = time.monotonic()
    kp = read_keypoints(path)
    assert time.monotonic() - t0 < 5
    assert kp.frame_ids.tolist() == list(range(10)) and kp.camera_names == ("cam01", "cam02")
    assert (kp.timestamps_ns >= 0).all() and not np.isnan(kp.keypoints[..., 0]).any()
    assert kp.ignored == {"cam01": IgnoredKeypoints(strays=1, stray_frame_ids=(2**40,), mistimed=0)}
    assert kp.restarts == {}  # the stray in the camera's series is not taken for a counter restart


def test_a_keypoint_message_with_a_good_frame_id_stamped_far_off_is_ignored_for_its_timestamp(tmp_path):
    """cam01's frame 5 stamped an hour early: left out and counted as mistimed (its id is one of the
    recording's), not read as the camera's first counter with the rest a restart."""
    from gaitcap.acquisition.recording.reader import read_keypoints
    from gaitcap.acquisition.recording.writer import TrialWriter, WriterSettings

    writer = TrialWriter(tmp_path / "m.mcap", WriterSettings())
    writer.start(metadata={"trial_id": "t"}, time_ns=1)
    people = [[[1.0, 2.0, 0.5]] * 26]
    for cam in ("cam01", "cam02"):
        for fid in range(10):
            ts = 10**18 + fid * 33_333_333 - (3600 * 10**9 if (cam, fid) == ("cam01", 5) else 0)
            writer.add_keypoints(cam, Keypoints(cam, fid, ts, "halpe26", people).to_bytes(), timestamp_ns=ts,
                                 frame_id=fid)
    kp = read_keypoints(writer.finish({}))
    assert kp.frame_ids.tolist() == list(range(10)) and kp.restarts == {}
    assert kp.ignored == {"cam01": IgnoredKeypoints(strays=1, stray_frame_ids=(5,), mistimed=1)}
    assert (kp.timestamps_ns[0] >= 10**18).tolist() == [f != 5 for f in range(10)]


def test_stray_frame_ids_around_a_restart_leave_the_restarted_frames_in_place(tmp_path):
    """cam01 restarts (its ids count again from 0, placed by time) with stray ids amid its first counter,
    at its end and amid the restarted one; cam02 has only stray frame ids: it is left out and named, not
    allocated for."""
    from gaitcap.acquisition.recording.reader import read_keypoints
    from gaitcap.acquisition.recording.writer import TrialWriter, WriterSettings

    period = 33_333_333
    writer = TrialWriter(tmp_path / "r.mcap", WriterSettings())
    writer.start(metadata={"trial_id": "t"}, time_ns=1)
    people = [[[1.0, 2.0, 0.5]] * 26]
    frames = [(k, k) for k in range(100, 130)]  # (frame set, frame id): the first counter
    frames += [(k, k - 140) for k in range(140, 170)]  # restarted at frame set 140, ids from 0 again
    frames += [(105, -(2**40)), (130, 7 * 10**9), (150, 3 * 10**9)]  # stray ids amid both counters
    for slot, fid in sorted(frames):
        ts = 10**18 + slot * period
        writer.add_keypoints("cam01", json.dumps({"camera": "cam01", "frame_id": fid, "timestamp_ns": ts,
                                                  "skeleton": "halpe26", "people": people}).encode(),
                             timestamp_ns=ts, frame_id=fid)
    for fid in (2**40, 2**70):  # 2**70: beyond any frame grid (not even an int64)
        writer.add_keypoints("cam02", json.dumps({"camera": "cam02", "frame_id": fid, "timestamp_ns": 10**18 + 120 * period,
                                                  "skeleton": "halpe26", "people": people}).encode(),
                             timestamp_ns=10**18 + 120 * period, frame_id=fid)
    kp = read_keypoints(writer.finish({}))
    assert kp.camera_names == ("cam01",) and kp.frame_ids.tolist() == list(range(100, 170))
    have = kp.timestamps_ns[0] >= 0
    assert have[:30].all() and not have[30:40].any() and have[40:].all()  # the restarted frames by time
    assert kp.restarts == {"cam01": 1}
    assert {c: i.strays for c, i in kp.ignored.items()} == {"cam01": 3, "cam02": 2}
    assert {c: i.stray_frame_ids for c, i in kp.ignored.items()} == {"cam01": (-(2**40), 7 * 10**9, 3 * 10**9),
                                                                      "cam02": (2**40, 2**70)}


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
