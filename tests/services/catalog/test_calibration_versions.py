"""Calibration versions in the catalog: a version 3 catalog opens upgraded with the versions table (every
calibration kept); a version names the one it replaces; applying it queues only the finished trials that
used the old one, names the others, and each queued trial then names the new version."""

import pytest
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import calibration_versions as versions
from gaitcap.services.catalog import calibrations as cals
from gaitcap.services.catalog.models import SCHEMA_VERSION

from .conftest import raw_sql


def _trial(db, cal_id: str, states: tuple[str, ...]) -> str:
    t = cat.start_trial(db, subject_id="P1", session="s1", calibration_id=cal_id,
                        recording_path_for=lambda tid: f"/rec/{tid}.mcap")
    for state in states:
        cat.set_state(db, t.id, state)
    return t.id


def test_a_version_3_catalog_opens_with_the_versions_table(fresh_catalog_url):
    path = fresh_catalog_url
    db = cat.open_catalog(path)
    cat.add_calibration(db, toml="[old]", cal_id="C-old")
    db.close()
    raw_sql(path, "DROP TABLE calibration_versions; UPDATE schema_info SET value = '3' WHERE key = 'version'")
    db = cat.open_catalog(path, create=False)
    assert cat.schema_version(db) == SCHEMA_VERSION == 6
    new = versions.add_version(db, toml="[new]", replaces_id="C-old", made_by="refine-rig", trials=["T1"],
                               comparison={"cam01": {"centre_mm": 1.0, "rotation_deg": 2.0, "focal_pct": 0.0}})
    assert versions.get_version(db, new).comparison["cam01"]["rotation_deg"] == 2.0
    assert cat.latest_calibration(db) == (new, "[new]") and cat.get_calibration(db, "C-old").state == "done"


def test_applying_a_version_queues_the_finished_trials_that_used_the_old_one(catalog_url):
    db = cat.open_catalog(catalog_url)
    old = cat.add_calibration(db, toml="[old]")
    other = cat.add_calibration(db, toml="[other]")
    done = _trial(db, old, ("recorded", "processing", "done"))
    failed = _trial(db, old, ("recorded", "processing", "failed"))
    busy = _trial(db, old, ("recorded", "processing"))
    elsewhere = _trial(db, other, ("recorded", "processing", "done"))
    new = versions.add_version(db, toml="[new]", replaces_id=old, made_by="refine-rig", trials=[done], comparison={})
    assert versions.lineage(db, new) == [new, old]
    queued, skipped = versions.apply_version(db, new)
    assert queued == [done, failed] and skipped == [f"{busy} (processing)"]
    for tid in queued:
        trial = cat.get_trial(db, tid)
        assert trial.state == "recorded" and trial.calibration_id == new
        assert versions.trial_version_toml(db, tid) == "[new]"
    assert cat.get_trial(db, elsewhere).calibration_id == other and versions.trial_version_toml(db, elsewhere) is None
    assert versions.trials_using(db, old) == [busy] and versions.get_version(db, new).applied_at is not None
    run = cals.start_board_recording(db, recording_path_for=lambda c: f"/d/{c}.mcap")
    with pytest.raises(ValueError, match=f"calibration {run.id} is recording: only a done calibration can be replaced"):
        versions.add_version(db, toml="[x]", replaces_id=run.id, made_by="t", trials=[], comparison={})
