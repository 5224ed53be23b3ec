"""A catalog written by schema version 2 (no board on the calibration record) opens upgraded to 3: every
calibration kept, the old ones without a board (they used the default board), new board recordings
record theirs; opening again changes nothing."""

import sqlite3

import pytest
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import calibrations as cals
from gaitcap.services.catalog.models import SCHEMA_VERSION

CHARUCO = {"kind": "charuco", "squares": [4, 5], "square_mm": 54.0, "dictionary": "DICT_4X4_50"}


@pytest.fixture
def v2(tmp_path):
    """A version 2 catalog: an upload and a finished board recording, stored before the board column."""
    path = tmp_path / "v2.sqlite"
    db = cat.open_catalog(path)
    cat.add_calibration(db, toml="[up]", source="uploaded by alice", cal_id="C1-up")
    run = cals.start_board_recording(db, recording_path_for=lambda c: f"/d/{c}.mcap", started_by="bob")
    cals.queue_calibration(db, run.id, frames=40)
    db.close()
    with sqlite3.connect(path) as con:
        con.execute("ALTER TABLE calibrations DROP COLUMN board")
        con.execute("UPDATE schema_info SET value = '2' WHERE key = 'version'")
    return path, run.id


def test_a_version_2_catalog_opens_upgraded_with_no_board_on_old_records(v2):
    path, run_id = v2
    db = cat.open_catalog(path)
    assert cat.schema_version(db) == SCHEMA_VERSION
    got = {c.id: c for c in cals.list_calibrations(db)}
    assert set(got) == {"C1-up", run_id}
    assert got["C1-up"].board is None and got[run_id].board is None
    assert (got[run_id].state, got[run_id].started_by, got[run_id].frames) == ("calibrating", "bob", 40)
    assert cat.latest_calibration(db) == ("C1-up", "[up]")
    cals.update_calibration(db, run_id, state=cals.FAILED, error="stopped")
    new = cals.start_board_recording(db, recording_path_for=lambda c: f"/d/{c}.mcap", board=CHARUCO)
    assert new.board == CHARUCO and cals.get_calibration(db, new.id).board == CHARUCO
    db.close()
    again = cat.open_catalog(path)
    assert cat.schema_version(again) == SCHEMA_VERSION and cals.get_calibration(again, new.id).board == CHARUCO
    with sqlite3.connect(path) as con:
        column = [r for r in con.execute("PRAGMA table_info(calibrations)") if r[1] == "board"]
    assert column and column[0][2] == "TEXT" and column[0][3] == 1  # TEXT NOT NULL
    again.close()
