"""A catalog written by schema version 5 (no rooms; on PostgreSQL a 16-character state column, too narrow for
done_with_warnings) opens upgraded to 6: its trials and calibrations in the default room, the one recording there still
holding the room's slot, new rooms registering beside it, every state storable."""

from gaitcap.services import catalog as cat
from gaitcap.services.catalog import rooms
from gaitcap.services.catalog.models import SCHEMA_VERSION
from sqlalchemy import inspect

from .conftest import raw_sql


def test_a_version_5_catalog_opens_with_its_trials_in_the_default_room(fresh_catalog_url):
    path = fresh_catalog_url
    db = cat.open_catalog(path)
    cal = cat.add_calibration(db, toml="[rig]")
    done = cat.start_trial(db, subject_id="P1", session="s1", recording_path_for=lambda t: f"/d/{t}.mcap")
    cat.set_state(db, done.id, "recorded")
    recording = cat.start_trial(db, subject_id="P2", session="s1", recording_path_for=lambda t: f"/d/{t}.mcap")
    db.close()
    narrow = "" if "://" not in path else "ALTER TABLE trials ALTER COLUMN state TYPE VARCHAR(16); "
    raw_sql(path, "DROP INDEX ix_trials_room; ALTER TABLE trials DROP COLUMN room; DROP INDEX ix_calibrations_room; "
                  "DROP INDEX ix_trials_created_at; "
                  f"ALTER TABLE calibrations DROP COLUMN room; DROP TABLE rooms; {narrow}"
                  "UPDATE schema_info SET value = '5' WHERE key = 'version'")
    db = cat.open_catalog(path, create=False)  # nothing created but by the upgrade
    assert cat.schema_version(db) == SCHEMA_VERSION == 6
    indexes = {i["name"] for i in inspect(db.engine).get_indexes("trials")}
    assert {"ix_trials_room", "ix_trials_created_at"} <= indexes
    assert {t.id: t.room for t in cat.list_trials(db)} == {done.id: "", recording.id: ""}
    assert cat.current_recording(db).id == recording.id and cat.latest_calibration(db) == (cal, "[rig]")
    rooms.register_room(db, "gait2")
    assert cat.start_trial(db, subject_id="P3", session="s1", room="gait2").room == "gait2"
    for state in ("processing", "done_with_warnings"):
        cat.set_state(db, done.id, state)
    assert cat.get_trial(db, done.id).state == "done_with_warnings"
    db.close()
