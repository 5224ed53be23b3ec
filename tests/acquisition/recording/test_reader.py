import json
import shutil

import numpy as np
import pytest
from gaitcap.acquisition.recording import layout
from gaitcap.acquisition.recording.reader import (
    is_complete,
    iter_frames,
    read_calibration,
    read_detections,
    read_keypoints,
    read_metadata,
    read_status,
    read_summary,
)
from gaitcap.acquisition.recording.recovery import recover
from recording_helpers import CAMS, FRAMES, J, people_for, tiny_rig, write_trial


def test_detections_aligned_by_frame_id_with_missing_as_nan(trial_mcap):
    det = read_detections(trial_mcap)
    assert det.camera_names == CAMS and det.shape == (3, FRAMES, J)
    assert det.skeleton.name == "halpe26"
    np.testing.assert_allclose(det.keypoints[2, 7], people_for(2, 7)[0])
    assert np.isnan(det.keypoints[1, 5, :, :2]).all() and (det.keypoints[1, 5, :, 2] == 0).all()
    np.testing.assert_allclose(np.diff(det.times_s), 1 / 30, atol=1e-4)
    assert det.times_s[0] == 0


def test_all_people_and_camera_subset(trial_mcap):
    kp = read_keypoints(trial_mcap, cameras=["cam2", "cam0"])
    assert kp.camera_names == ("cam2", "cam0") and kp.people.shape == (2, FRAMES, 2, J, 3)
    np.testing.assert_allclose(kp.people[0, 3, 1], people_for(2, 3)[1])
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
    assert read_detections(tmp_path / "crash.mcap").shape == (3, FRAMES, J)
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
