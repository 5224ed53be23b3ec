import json
import logging
import shutil

import numpy as np
import pytest
from gaitcap.acquisition.recording import layout
from gaitcap.acquisition.recording.reader import (
    is_complete,
    iter_frames,
    read_calibration,
    read_detections,
    read_image_times,
    read_keypoints,
    read_metadata,
    read_status,
    read_summary,
)
from gaitcap.acquisition.recording.recovery import recover
from gaitcap.reconstruction.calibration_io import rig_to_toml_text
from recording_helpers import CAMS, FRAMES, PERIOD_NS, T0_NS, J, people_for, tiny_rig, write_trial


def test_detections_aligned_by_frame_id_with_missing_as_nan(trial_mcap):
    det = read_detections(trial_mcap)
    assert det.camera_names == CAMS and det.shape == (3, FRAMES, 1, J)
    assert det.skeleton.name == "halpe26"
    np.testing.assert_allclose(det.one_person[2, 7], people_for(2, 7)[0])
    assert np.isnan(det.one_person[1, 5, :, :2]).all() and (det.one_person[1, 5, :, 2] == 0).all()
    np.testing.assert_allclose(np.diff(det.times_s), 1 / 30, atol=1e-4)
    assert det.times_s[0] == 0


def test_all_people_and_camera_subset(trial_mcap):
    kp = read_keypoints(trial_mcap, cameras=["cam2", "cam0"])
    assert kp.camera_names == ("cam2", "cam0") and kp.keypoints.shape == (2, FRAMES, 2, J, 3)
    np.testing.assert_allclose(kp.keypoints[0, 3, 1], people_for(2, 3)[1])
    with pytest.raises(ValueError, match="camX"):
        read_keypoints(trial_mcap, cameras=["camX"])


def test_calibration_metadata_status_summary(trial_mcap):
    rig = read_calibration(trial_mcap)
    assert rig.names == list(CAMS)
    np.testing.assert_allclose(rig["cam1"].tvec_mm, tiny_rig()["cam1"].tvec_mm)
    assert read_metadata(trial_mcap) == {"patient": "p01", "speed": 1.2}
    assert len(read_status(trial_mcap)["cam0"]) == FRAMES
    assert read_summary(trial_mcap) == {"frames": 3 * FRAMES}  # what the writer was handed


def test_iter_frames_one_camera_decodes(trial_mcap):
    frames = list(iter_frames(trial_mcap, camera="cam1"))
    assert [f.frame_id for f in frames] == [i for i in range(FRAMES) if i not in (5, 6)]
    assert frames[0].image().shape == (48, 64, 3)
    assert len(list(iter_frames(trial_mcap))) == 3 * FRAMES - 2


def test_part_file_recovered_every_complete_chunk(tmp_path):
    part = write_trial(tmp_path / "crash.mcap", finish=False, flush_every=5)
    assert part.name == "crash.mcap.part" and not is_complete(part)
    # The reader finds the .part file under the final name and reads it by scanning.
    assert read_detections(tmp_path / "crash.mcap").shape == (3, FRAMES, 1, J)
    report = recover(tmp_path / "crash.mcap")
    assert report.output == tmp_path / "crash.mcap" and is_complete(report.output)
    assert report.messages[layout.image_topic("cam0")] == FRAMES
    assert read_metadata(report.output)["patient"] == "p01"
    assert read_calibration(report.output).names == list(CAMS)
    assert read_summary(report.output)["recovered"] is True


def test_truncated_copies_never_hang_and_lose_only_the_cut_chunk(tmp_path):
    full = write_trial(tmp_path / "full.mcap", flush_every=5)
    data = full.read_bytes()
    previous = -1
    for frac in (0.2, 0.45, 0.7, 0.95):
        cut = tmp_path / f"cut{frac}.mcap.part"
        cut.write_bytes(data[: int(len(data) * frac)])
        report = recover(cut, tmp_path / f"rec{frac}.mcap")
        n = report.messages.get(layout.image_topic("cam0"), 0)
        assert n >= previous and report.error  # more data -> at least as many frames; the cut is named
        previous = n
    assert previous >= FRAMES - 5


def test_corrupt_chunk_is_skipped_not_fatal(tmp_path):
    full = write_trial(tmp_path / "full.mcap", compression="none", flush_every=5)
    data = bytearray(full.read_bytes()[:-200])  # also cut the summary away
    mid = data.index(b"\xff\xd8\xff", len(data) // 2)  # inside a JPEG of an image chunk
    data[mid : mid + 64] = bytes(64)
    bad = tmp_path / "bad.mcap.part"
    bad.write_bytes(bytes(data))
    report = recover(bad, tmp_path / "fixed.mcap")
    total = sum(n for t, n in report.messages.items() if layout.is_image_topic(t))
    assert 0 < total < 3 * FRAMES


@pytest.mark.parametrize("content", [b"", b"not an mcap at all", b"\x89MCAP0\r\n"])
def test_garbage_gives_a_clear_error(tmp_path, content):
    p = tmp_path / "g.mcap"
    p.write_bytes(content)
    with pytest.raises(ValueError, match="g.mcap"):
        read_detections(p)


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothere"):
        read_metadata(tmp_path / "nothere.mcap")


def test_recover_refuses_to_overwrite(tmp_path):
    part = write_trial(tmp_path / "c.mcap", finish=False)
    shutil.copy(part, tmp_path / "c.mcap")
    with pytest.raises(ValueError, match="exists"):
        recover(part)


def test_keypoints_json_schema_is_documented(trial_mcap):
    schema = json.loads(layout.json_schema("gaitcap.Keypoints2D"))
    assert set(schema["required"]) == {"camera", "frame_id", "timestamp_ns", "skeleton", "people"}


def test_corrupt_chunk_in_a_complete_file_is_a_clear_error_and_recoverable(tmp_path):
    full = write_trial(tmp_path / "full.mcap", compression="lz4", flush_every=5)
    data = bytearray(full.read_bytes())
    mid = data.index(b"\xff\xd8\xff", len(data) // 3)  # inside an image chunk's lz4 frame
    data[mid - 200 : mid + 200] = bytes(range(256)) + bytes(144)
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    with pytest.raises(ValueError, match="bad.mcap: corrupt data"):
        list(iter_frames(bad))
    report = recover(bad)  # keeps the chunks before the damage, names where it stopped
    assert report.output == tmp_path / "bad.recovered.mcap" and not report.was_complete
    assert report.error and 0 < report.messages[layout.image_topic("cam0")] < FRAMES
    assert read_metadata(report.output)["patient"] == "p01"


def _write_restart(path, *, restarted=("cam0", "cam1"), before=40, gap=10, after=30, first_id=500):
    """Every camera records ids first_id.. for ``before`` frames; the ``restarted`` cameras then go dark for
    ``gap`` frames and start their counters again at 0 (same clock), the others keep counting."""
    from gaitcap.acquisition.recording.writer import TrialWriter

    w = TrialWriter(path)
    w.start(metadata={"trial_id": "restart"}, calibration_toml=rig_to_toml_text(tiny_rig()), time_ns=T0_NS)
    for c, cam in enumerate(CAMS):
        for k in range(before + gap + after):
            again = cam in restarted and k >= before
            if again and k < before + gap:
                continue
            fid = k - before - gap if again else first_id + k
            ts = T0_NS + k * PERIOD_NS + 1000 * c
            kp = {"camera": cam, "frame_id": fid, "timestamp_ns": ts, "skeleton": "halpe26",
                  "people": people_for(c, k).tolist()}
            w.add_keypoints(cam, json.dumps(kp).encode(), timestamp_ns=ts, frame_id=fid)
    return w.finish({})


def test_a_camera_restart_within_the_trial_is_read_by_time_not_refused(tmp_path, caplog):
    path = _write_restart(tmp_path / "restart.mcap")
    kp = read_keypoints(path)
    assert kp.frame_ids[0] == 500 and kp.frame_ids.size == 80
    assert np.all(np.diff(kp.times_s) > 0)
    np.testing.assert_allclose(np.diff(kp.times_s), PERIOD_NS / 1e9, atol=1e-5)
    for c in range(3):  # frame k of every camera is in frame set k, restarted or not
        for k in (0, 39, 50, 79):
            np.testing.assert_allclose(kp.keypoints[c, k, :2], people_for(c, k))
    assert np.isnan(kp.keypoints[0, 40:50, 0, :, 0]).all() and not np.isnan(kp.keypoints[2, 40:50, 0, :, 0]).any()
    assert "camera cam0: frame counter restarted 1 time within" in caplog.text and "cam2: frame" not in caplog.text
    assert kp.restarts == {"cam0": 1, "cam1": 1}


def test_every_camera_restarted_together_is_placed_after_the_gap(tmp_path):
    kp = read_keypoints(_write_restart(tmp_path / "all.mcap", restarted=CAMS, first_id=0))
    assert kp.frame_ids.size == 80 and np.all(np.diff(kp.times_s) > 0)
    np.testing.assert_allclose(kp.keypoints[1, 60, :2], people_for(1, 60))
    assert kp.restarts == {"cam0": 1, "cam1": 1, "cam2": 1}


def test_image_times_from_the_index_match_a_scan_of_the_cut_file(tmp_path):
    part = write_trial(tmp_path / "crash.mcap", finish=False, flush_every=5, missing={"cam1": {3, 4}})
    scanned = read_image_times(part)  # no index in a cut file: its records are scanned
    report = recover(part)
    indexed = read_image_times(report.output)  # through the message index
    assert sorted(indexed) == sorted(scanned) == list(CAMS)
    for cam in CAMS:
        np.testing.assert_array_equal(indexed[cam], scanned[cam])
    kept = [f for f in range(FRAMES) if f not in (3, 4)]
    np.testing.assert_array_equal(indexed["cam1"], T0_NS + np.array(kept) * PERIOD_NS + 1000)
    assert list(read_image_times(report.output, cameras=["cam2"])) == ["cam2"]


def test_a_repeated_frame_id_is_a_duplicate_not_a_restart(caplog):
    from gaitcap.acquisition.recording.frame_slots import align_frame_slots

    ids = np.array([10, 11, 12, 12, 13])
    ts = T0_NS + np.array([0, 1, 2, 2, 3]) * PERIOD_NS + np.array([0, 0, 0, 5, 0])
    placed, report = align_frame_slots({"cam0": (ids, ts), "cam1": (ids[[0, 1, 2, 4]], ts[[0, 1, 2, 4]])})
    assert report.restarts == {} and report.dropped == {"cam0": 1}
    keep, slots = placed["cam0"]
    assert slots.tolist() == [10, 11, 12, 13] and keep.tolist() == [0, 1, 2, 4]
    assert "cam0: 1 frame repeats a frame already recorded and was left out" in caplog.text


def test_image_times_scan_the_file_when_the_index_points_at_something_else(tmp_path):
    from mcap.reader import make_reader

    path = write_trial(tmp_path / "t.mcap")
    good = read_image_times(path)
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    a, b = [c for c, ch in summary.channels.items() if layout.is_image_topic(ch.topic)][:2]
    data = bytearray(path.read_bytes())
    start = summary.chunk_indexes[0].chunk_start_offset + 1  # past the data section's first chunk
    swapped = 0
    for ci in summary.chunk_indexes:  # the summary's chunk indexes send camera a to camera b's index records
        if a in ci.message_index_offsets and b in ci.message_index_offsets:
            pa, pb = (cid.to_bytes(2, "little") + ci.message_index_offsets[cid].to_bytes(8, "little") for cid in (a, b))
            at, bt = data.index(pa, start), data.index(pb, start)
            data[at + 2: at + 10], data[bt + 2: bt + 10] = pb[2:], pa[2:]
            swapped += 1
    assert swapped
    path.write_bytes(bytes(data))
    times = read_image_times(path)  # the index records name other channels: the file is scanned instead
    assert sorted(times) == sorted(good)
    for cam in good:
        np.testing.assert_array_equal(times[cam], good[cam])


def test_malformed_keypoint_messages_are_ignored_and_counted_with_why(tmp_path, caplog):
    """Keypoint messages that cannot be read (bad JSON, a field missing, people of another joint count)
    are left out and counted per camera with why; the recording is read, not refused. A camera with only
    such messages has no keypoints (not in camera_names), and is counted all the same."""
    from gaitcap.acquisition.recording.writer import TrialWriter

    w = TrialWriter(tmp_path / "bad.mcap")
    w.start(metadata={"trial_id": "bad"}, calibration_toml=rig_to_toml_text(tiny_rig()), time_ns=T0_NS)
    good = {}
    for c, cam in enumerate(CAMS[:2]):
        for k in range(FRAMES):
            ts = T0_NS + k * PERIOD_NS + 1000 * c
            good[cam, k] = {"camera": cam, "frame_id": k, "timestamp_ns": ts, "skeleton": "halpe26",
                            "people": people_for(c, k).tolist()}
            data = json.dumps(good[cam, k]).encode()
            if cam == "cam1" and k in (3, 7):
                data = json.dumps({f: v for f, v in good[cam, k].items() if f != "skeleton"}).encode()
            elif cam == "cam1" and k == 9:
                data = data[: len(data) // 2]  # cut JSON
            elif cam == "cam0" and k == 5:
                data = json.dumps({**good[cam, k], "people": [[[1.0, 2.0, 0.5]] * 17]}).encode()
            w.add_keypoints(cam, data, timestamp_ns=ts, frame_id=k)
    for k in range(2):  # cam2: every message lacks its timestamp
        w.add_keypoints("cam2", json.dumps({"camera": "cam2", "frame_id": k, "skeleton": "halpe26",
                                            "people": []}).encode(), timestamp_ns=T0_NS + k, frame_id=k)
    with caplog.at_level(logging.WARNING):
        kp = read_keypoints(w.finish({}))
    assert kp.camera_names == ("cam0", "cam1") and kp.frame_ids.tolist() == list(range(FRAMES))
    # said in the log too (gaitcap process on a trial file keeps no quality record)
    assert "camera cam1: 3 keypoint message(s) could not be read and were ignored (2 missing 'skeleton', " \
           "1 not JSON)" in caplog.text
    assert "camera cam2: 2 keypoint message(s) could not be read" in caplog.text
    assert {c: i.unreadable for c, i in kp.ignored.items()} == {
        "cam0": {"people with 17 joints where the others have 26": 1},
        "cam1": {"missing 'skeleton'": 2, "not JSON": 1},
        "cam2": {"missing 'timestamp_ns'": 2}}
    assert {c: i.strays for c, i in kp.ignored.items()} == {"cam0": 0, "cam1": 0, "cam2": 0}
    have = kp.timestamps_ns >= 0
    assert have[0].tolist() == [k != 5 for k in range(FRAMES)]
    assert have[1].tolist() == [k not in (3, 7, 9) for k in range(FRAMES)]
    np.testing.assert_allclose(kp.keypoints[1, 8, :2], people_for(1, 8))
    with pytest.raises(ValueError, match=r"cameras \['cam2'\].*missing 'timestamp_ns'"):
        read_keypoints(tmp_path / "bad.mcap", cameras=["cam0", "cam2"])


def test_keypoint_messages_no_frame_grid_can_hold_are_ignored_counted_and_logged(tmp_path, caplog):
    """A frame id beyond +-2**53 or a timestamp outside 0..2**63 ns: left out before placing, counted as
    strays of the camera (mistimed when the frame id is the recording's), and said in the log."""
    from gaitcap.acquisition.recording.writer import TrialWriter
    from gaitcap.reconstruction.ignored_keypoints import IgnoredKeypoints

    w = TrialWriter(tmp_path / "far.mcap")
    w.start(metadata={"trial_id": "far"}, calibration_toml=rig_to_toml_text(tiny_rig()), time_ns=T0_NS)
    for c, cam in enumerate(CAMS[:2]):
        for k in range(FRAMES):
            ts = T0_NS + k * PERIOD_NS + 1000 * c
            w.add_keypoints(cam, json.dumps({"camera": cam, "frame_id": k, "timestamp_ns": ts, "skeleton": "halpe26",
                                             "people": people_for(c, k).tolist()}).encode(), timestamp_ns=ts, frame_id=k)
    for fid, stamp in ((2**60, T0_NS), (3, -1)):
        w.add_keypoints("cam1", json.dumps({"camera": "cam1", "frame_id": fid, "timestamp_ns": stamp,
                                            "skeleton": "halpe26", "people": []}).encode(), timestamp_ns=T0_NS,
                        frame_id=3)
    with caplog.at_level(logging.WARNING):
        kp = read_keypoints(w.finish({}))
    assert kp.camera_names == ("cam0", "cam1") and kp.frame_ids.tolist() == list(range(FRAMES))
    assert kp.ignored == {"cam1": IgnoredKeypoints(2, (2**60, 3), 1, {})}
    assert (f"camera cam1: 2 keypoint message(s) with a frame id beyond +-2**53 or a timestamp outside 0..2**63 ns "
            f"were ignored (from frame id {2**60})") in caplog.text


def test_a_joint_not_seen_recorded_as_nan_is_kept_and_a_confidence_outside_0_to_1_is_ignored_with_why(tmp_path):
    """A recording written by a tool whose JSON has NaN: a joint not seen (NaN, confidence 0) is read as
    missing; a message with a confidence of 1.5, or NaN coordinates with confidence 0.4, is left out and
    counted with why, the rest of its camera read."""
    from gaitcap.acquisition.recording.writer import TrialWriter

    w = TrialWriter(tmp_path / "nan.mcap")
    w.start(metadata={"trial_id": "nan"}, calibration_toml=rig_to_toml_text(tiny_rig()), time_ns=T0_NS)
    for c, cam in enumerate(CAMS[:2]):
        for k in range(FRAMES):
            ts = T0_NS + k * PERIOD_NS + 1000 * c
            people = people_for(c, k)
            if (cam, k) == ("cam0", 4):
                people[0, 7] = [np.nan, np.nan, 0.0]
            elif (cam, k) == ("cam1", 6):
                people[1, 2, 2] = 1.5
            elif (cam, k) == ("cam1", 8):
                people[0, 0] = [np.nan, 3.0, 0.4]
            w.add_keypoints(cam, json.dumps({"camera": cam, "frame_id": k, "timestamp_ns": ts, "skeleton": "halpe26",
                                             "people": people.tolist()}).encode(), timestamp_ns=ts, frame_id=k)
    kp = read_keypoints(w.finish({}))
    assert kp.camera_names == ("cam0", "cam1") and (kp.timestamps_ns[0] >= 0).all()
    assert np.isnan(kp.keypoints[0, 4, 0, 7, :2]).all() and kp.keypoints[0, 4, 0, 7, 2] == 0
    np.testing.assert_allclose(kp.keypoints[0, 4, 0, 8], people_for(0, 4)[0, 8])
    assert (kp.timestamps_ns[1] >= 0).tolist() == [k not in (6, 8) for k in range(FRAMES)]
    assert {c: i.unreadable for c, i in kp.ignored.items()} == {"cam1": {
        "'people' confidence not a number in 0..1": 1,
        "'people' x NaN with a confidence above 0 (a joint not seen has confidence 0)": 1}}


def test_frame_times_always_increase_when_a_camera_stamps_a_frame_off_its_slot(caplog):
    """Two software-timed cameras 0.4 period apart; one frame stamped 0.7 period late, alone in its frame set,
    the next set's only frame from the other camera: the medians would go back; the times are held to the
    frame grid and said, and a recording whose times increase is left to the ns."""
    from gaitcap.acquisition.recording.reader import frame_times_s

    period = 33_333_333
    t0 = 1_700_000_000_000_000_000
    stamps = np.full((2, 40), -1, dtype=np.int64)
    stamps[:, :] = t0 + np.arange(40) * period + np.array([[0], [-int(0.4 * period)]])
    on_grid = frame_times_s(stamps)
    assert np.allclose(np.diff(on_grid), period / 1e9, atol=2e-9)
    stamps[1, 10], stamps[0, 11] = -1, -1  # set 10: cam0 only, late; set 11: cam1 only, on time
    stamps[0, 10] = t0 + int(10.7 * period)
    stamps[1, 11] = t0 + 11 * period - int(0.4 * period)
    with caplog.at_level("WARNING"):
        times = frame_times_s(stamps)
    assert np.all(np.diff(times) > 0), np.diff(times)
    assert "held to their frame grid" in caplog.text and "of 40 frame sets" in caplog.text, caplog.text
    # the two sets are held within 0.45 period of their slots; every other set keeps its median stamp
    assert np.all(np.abs(times[10:12] - on_grid[10:12]) <= 0.45 * period / 1e9 + 1e-9)
    others = np.r_[0:10, 12:40]
    assert np.allclose(times[others], on_grid[others], atol=1e-6)


def test_frame_sets_held_to_their_grid_are_counted():
    from gaitcap.acquisition.recording.reader import frame_sets_held

    period, t0 = 33_333_333, 1_700_000_000_000_000_000
    stamps = t0 + np.arange(40) * period + np.array([[0], [-int(0.4 * period)]])
    assert frame_sets_held(stamps) == 0
    stamps[1, 10], stamps[0, 11] = -1, -1  # as above: two frame sets stamped out of order
    stamps[0, 10], stamps[1, 11] = t0 + int(10.7 * period), t0 + 11 * period - int(0.4 * period)
    assert frame_sets_held(stamps) == 1  # the late one moved back; the next set keeps its stamp
