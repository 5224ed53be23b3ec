import json
import sys
import threading
import time
from pathlib import Path

import pytest
from gaitcap.acquisition.encoding import parse_image_message
from gaitcap.services.bus.session import BusConfig, open_session
from gaitcap.services.cli.replay import _rate
from gaitcap.services.nodes.replay import Replayer

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "acquisition" / "recording"))
from recording_helpers import CAMS, FRAMES, write_trial  # noqa: E402


def free_bus(names, prefix="gaitcap/rp"):
    return BusConfig.free_local(names, prefix=prefix)


def _replay(path, rate, keypoints=True):
    bus = free_bus(["replay", "sink"])
    sr, ss = open_session(bus, "replay"), open_session(bus, "sink")
    got, lock = [], threading.Lock()

    def on(sample):
        with lock:
            att = json.loads(sample.attachment.to_bytes()) if sample.attachment is not None else None
            if att is not None:  # the camera timestamp travels once: in the frame's protobuf
                att["timestamp_ns"] = parse_image_message(sample.payload.to_bytes()).timestamp_ns
            got.append((str(sample.key_expr), att, time.monotonic()))

    subs = [ss.declare_subscriber(f"{bus.prefix}/**", on)]
    try:
        time.sleep(0.5)
        stats = Replayer(sr, bus.keys, rate=rate, keypoints=keypoints).run(path)
        time.sleep(0.3)
        with lock:
            return stats, list(got), bus
    finally:
        for s in subs:
            s.undeclare()
        sr.close()
        ss.close()


def test_replay_in_real_time_keeps_frame_ids_and_timestamps(tmp_path):
    path = write_trial(tmp_path / "t.mcap", missing={"cam1": {5, 6}})
    stats, got, bus = _replay(path, rate=1.0)
    assert stats.frames == len(CAMS) * FRAMES - 2 and stats.keypoints == stats.frames
    assert stats.duration_s == pytest.approx((FRAMES - 1) / 30, abs=0.1)
    frames = [(k, a) for k, a, _ in got if k.endswith("/image")]
    cam1 = [a["frame_id"] for k, a in frames if k == bus.keys.image("cam1")]
    assert cam1 == [i for i in range(FRAMES) if i not in (5, 6)]
    a = next(a for k, a in frames if k == bus.keys.image("cam2"))
    assert a["timestamp_ns"] == 1_700_000_000_000_000_000 + 2000 and a["replay"] is True
    assert sum(k.endswith("/status") for k, _, _ in got) == FRAMES


def test_replay_max_rate_without_keypoints_and_a_crashed_file(tmp_path):
    part = write_trial(tmp_path / "c.mcap", finish=False, flush_every=5)
    stats, got, _ = _replay(tmp_path / "c.mcap", rate=None, keypoints=False)
    assert stats.frames == len(CAMS) * FRAMES and stats.keypoints == 0 and stats.duration_s < 0.5
    assert not any("/keypoints/" in k for k, _, _ in got) and part.exists()


def test_rate_option():
    assert _rate("max") is None and _rate("2.5") == 2.5
    with pytest.raises(ValueError, match="--rate"):
        _rate("fast")
    with pytest.raises(ValueError, match="rate"):
        Replayer(None, None, rate=0)
