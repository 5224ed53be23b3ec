"""A trial's files: fixed names inside the trial's folder; the recording where the catalog says it is."""

from pathlib import Path

import pytest
from gaitcap.services.processing.artifacts import trial_files


def test_the_recording_is_where_the_catalog_records_it(tmp_path):
    assert trial_files(tmp_path, "T1").recording == tmp_path / "trials" / "T1" / "recording.mcap"
    moved = tmp_path / "archive" / "walk.mcap"
    files = trial_files(tmp_path, "T1", str(moved))
    assert files.recording == moved and files.people_json == tmp_path / "trials" / "T1" / "people.json"
    assert trial_files(tmp_path, "T1", "").recording == tmp_path / "trials" / "T1" / "recording.mcap"


def test_ids_and_names_are_checked():
    with pytest.raises(ValueError, match="trial_id"):
        trial_files(Path("/data"), "../etc")
    with pytest.raises(ValueError, match="artifact"):
        trial_files(Path("/data"), "T1").stage_file("refined", "nope")


def test_removing_a_trial_takes_its_recording_wherever_it_is_and_names_what_stays(tmp_path):
    from gaitcap.services.processing.artifacts import remove_trial_files

    files = trial_files(tmp_path, "T1", str(tmp_path / "archive" / "T1.mcap"))
    (files.root / "refined").mkdir(parents=True)
    (files.root / "refined" / "gait.json").write_text("{}")
    files.recording.parent.mkdir()
    files.recording.write_bytes(b"mcap")
    files.recording.with_name("T1.mcap.part").write_bytes(b"part")
    assert remove_trial_files(files) == [] and not files.root.exists() and not files.recording.exists()
    stuck = trial_files(tmp_path, "T2", str(tmp_path / "stuck"))
    (tmp_path / "stuck").mkdir()
    (tmp_path / "stuck" / "x").write_text("not a file we may unlink")
    assert remove_trial_files(stuck) == [tmp_path / "stuck"]
