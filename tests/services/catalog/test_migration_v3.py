"""A catalog written by schema version 2 (no board on the calibration record) opens upgraded to 3: every
calibration kept, the old ones without a board (they used the default board), new board recordings
record theirs; opening again changes nothing."""

import pytest
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import calibrations as cals
from gaitcap.services.catalog.models import SCHEMA_VERSION
from sqlalchemy import inspect

from .conftest import raw_sql

CHARUCO = {"kind": "charuco", "squares": [4, 5], "square_mm": 54.0, "dictionary": "DICT_4X4_50"}


@pytest.fixture
def v2(fresh_catalog_url):
    """A version 2 catalog: an upload and a finished board recording, stored before the board column."""
    path = fresh_catalog_url
    db = cat.open_catalog(path)
    cat.add_calibration(db, toml="[up]", source="uploaded by alice", cal_id="C1-up")
    run = cals.start_board_recording(db, recording_path_for=lambda c: f"/d/{c}.mcap", started_by="bob")
    cals.queue_calibration(db, run.id, frames=40)
    db.close()
    raw_sql(path, "ALTER TABLE calibrations DROP COLUMN board; UPDATE schema_info SET value = '2' WHERE key = 'version'")
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
    column = [c for c in inspect(again.engine).get_columns("calibrations") if c["name"] == "board"]
    assert column and str(column[0]["type"]) == "TEXT" and not column[0]["nullable"]  # TEXT NOT NULL
    again.close()
