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
