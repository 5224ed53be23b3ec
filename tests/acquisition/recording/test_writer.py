import json

import pytest
from gaitcap.acquisition.recording import layout
from gaitcap.acquisition.recording.writer import TrialWriter, WriterSettings
from mcap.reader import make_reader


def _load(path):
    f = open(path, "rb")
    return f, make_reader(f)


def test_complete_file_opens_with_mcap_reader(trial_mcap):
    f, reader = _load(trial_mcap)
    with f:
        summary = reader.get_summary()
        topics = {c.topic for c in summary.channels.values()}
        assert layout.image_topic("cam0") in topics and layout.keypoints_topic("cam2") in topics
        assert layout.TRIAL_METADATA_TOPIC in topics and layout.CALIBRATION_TOPIC in topics
        counts = {summary.channels[cid].topic: n for cid, n in summary.statistics.channel_message_counts.items()}
        assert counts[layout.image_topic("cam1")] == 18 and counts[layout.image_topic("cam0")] == 20
        assert [a.name for a in reader.iter_attachments()] == [layout.CALIBRATION_ATTACHMENT]
        names = [m.name for m in reader.iter_metadata()]
        assert names == [layout.TRIAL_METADATA_RECORD, layout.SUMMARY_RECORD]


def test_keypoints_live_in_chunks_without_images(trial_mcap):
    f, reader = _load(trial_mcap)
    with f:
        summary = reader.get_summary()
        kinds = []
        for chunk in summary.chunk_indexes:
            topics = {summary.channels[cid].topic for cid in chunk.message_index_offsets}
            has_img = any(layout.is_image_topic(t) for t in topics)
            has_kp = any(layout.is_keypoints_topic(t) for t in topics)
            assert not (has_img and has_kp), f"chunk mixes images and keypoints: {topics}"
            kinds.append(has_kp)
        assert any(kinds) and not all(kinds)


def test_frame_sequence_is_frame_id_and_log_time_camera_time(trial_mcap):
    f, reader = _load(trial_mcap)
    with f:
        for _, _channel, msg in reader.iter_messages(topics=[layout.image_topic("cam2")]):
            assert msg.log_time == 1_700_000_000_000_000_000 + msg.sequence * 33_333_333 + 2000


def test_writer_refuses_existing_or_bad_paths(tmp_path, trial_mcap):
    with pytest.raises(ValueError, match="already exists"):
        TrialWriter(trial_mcap)
    with pytest.raises(ValueError, match=r"\.mcap"):
        TrialWriter(tmp_path / "x.bag")
    with pytest.raises(ValueError, match="does not exist"):
        TrialWriter(tmp_path / "nope" / "x.mcap")
    with pytest.raises(ValueError, match="compression"):
        WriterSettings(compression="zip")


def test_part_file_until_finish(tmp_path):
    w = TrialWriter(tmp_path / "t.mcap", WriterSettings(compression="none"))
    w.start(metadata={"a": [1, 2]}, time_ns=1)
    assert w.part_path.exists() and not (tmp_path / "t.mcap").exists()
    final = w.finish({"frames": 0})
    assert final.exists() and not w.part_path.exists()
    f, reader = _load(final)
    with f:
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
    assert json.loads(meta["trial"]["a"]) == [1, 2]
