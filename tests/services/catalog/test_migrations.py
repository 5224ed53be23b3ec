"""A catalog written by schema version 1 (two calibration tables, jobs only for trials) opens upgraded:
every calibration and board recording kept as one record, the active one unchanged, the jobs kept and
takeable, calibration jobs possible; opening again changes nothing."""

import sqlite3

import pytest
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import calibrations as cals
from gaitcap.services.catalog.migrations import portable
from gaitcap.services.catalog.models import SCHEMA_VERSION
from sqlalchemy import inspect
from sqlalchemy.engine import make_url

from .conftest import raw_sql

V1_TABLES = """
DROP TABLE jobs; DROP TABLE calibrations;
CREATE TABLE calibrations (id VARCHAR(64) NOT NULL, created_at FLOAT NOT NULL, source VARCHAR(256) NOT NULL,
    toml TEXT NOT NULL, report_json TEXT NOT NULL, PRIMARY KEY (id));
CREATE TABLE calibration_runs (id VARCHAR(64) NOT NULL, state VARCHAR(16) NOT NULL, recording_slot INTEGER,
    created_at FLOAT NOT NULL, started_at FLOAT, stopped_at FLOAT, started_by VARCHAR(128) NOT NULL,
    recording_path VARCHAR(1024) NOT NULL, stage VARCHAR(64) NOT NULL, progress FLOAT NOT NULL, error TEXT NOT NULL,
    toml TEXT NOT NULL, report_json TEXT NOT NULL, calibration_id VARCHAR(64), PRIMARY KEY (id), UNIQUE (recording_slot));
CREATE INDEX ix_calibration_runs_state ON calibration_runs (state);
CREATE TABLE jobs (id INTEGER NOT NULL, trial_id VARCHAR(64) NOT NULL, kind VARCHAR(32) NOT NULL,
    state VARCHAR(16) NOT NULL, attempts INTEGER NOT NULL, max_attempts INTEGER NOT NULL, worker_id VARCHAR(128) NOT NULL,
    lease_expires_at FLOAT NOT NULL, created_at FLOAT NOT NULL, started_at FLOAT, finished_at FLOAT, error TEXT NOT NULL,
    PRIMARY KEY (id), FOREIGN KEY(trial_id) REFERENCES trials (id));
CREATE INDEX ix_jobs_state ON jobs (state);
CREATE INDEX ix_jobs_trial_id ON jobs (trial_id);
UPDATE schema_info SET value = '1' WHERE key = 'version';
"""
V1_ROWS = """
INSERT INTO calibrations VALUES ('C1-up', 100.0, 'uploaded by alice', '[up]', '{}');
INSERT INTO calibrations VALUES ('C2-board', 300.0, 'board recording by bob', '[board]', '{}');
INSERT INTO calibration_runs VALUES ('C2-board', 'done', NULL, 200.0, 200.0, 250.0, 'bob', '/d/c2.mcap', '', 1.0, '',
    '[board]', '{"rms_px": 0.4}', 'C2-board');
INSERT INTO calibration_runs VALUES ('C3-bad', 'failed', NULL, 400.0, 400.0, 450.0, 'bob', '/d/c3.mcap', '', 1.0,
    'cameras cam02 failed', '[bad]', '{"rms_px": 0.4}', NULL);
"""


def _dialect(url: str) -> str:
    return make_url(url).get_backend_name() if "://" in url else "sqlite"


def _version(url: str) -> str:
    return raw_sql(url, "SELECT value FROM schema_info WHERE key = 'version'")[0][0]


@pytest.fixture
def v1(fresh_catalog_url):
    """A version 1 catalog: an upload (t=100 s), a passing board recording (started 200 s, its calibration
    stored at 300 s: the active one), a failed one (400 s), a trial with a queued job (SQLite or PostgreSQL,
    the tables as that database had them: the job's number is SERIAL on PostgreSQL)."""
    path = fresh_catalog_url
    db = cat.open_catalog(path)
    trial = cat.start_trial(db, subject_id="P1", session="s1", recording_path_for=lambda t: f"/d/{t}.mcap")
    cat.set_state(db, trial.id, "recorded")
    db.close()
    v1_tables = V1_TABLES if _dialect(path) == "sqlite" else V1_TABLES.replace(  # trials' key to it goes too
        "DROP TABLE calibrations;", "DROP TABLE calibrations CASCADE;")
    raw_sql(path, portable(v1_tables, _dialect(path)) + V1_ROWS
            + f"; INSERT INTO jobs VALUES (1, '{trial.id}', 'process', 'queued', 0, 3, '', 0.0, 500.0, NULL, NULL, '')")
    return path, trial.id


def test_a_version_1_catalog_opens_upgraded_with_everything_kept(v1):
    path, tid = v1
    db = cat.open_catalog(path)
    assert cat.schema_version(db) == SCHEMA_VERSION
    assert cat.latest_calibration(db) == ("C2-board", "[board]")  # still the active one
    got = {c.id: c for c in cals.list_calibrations(db)}
    assert [c.id for c in cals.list_calibrations(db)] == ["C3-bad", "C2-board", "C1-up"]
    assert (got["C1-up"].kind, got["C1-up"].state, got["C1-up"].source) == ("uploaded", "done", "uploaded by alice")
    board = got["C2-board"]
    assert (board.kind, board.state, board.started_by, board.recording_path) == ("board recording", "done", "bob",
                                                                                "/d/c2.mcap")
    assert (board.created_at, board.done_at, board.report) == (200.0, 300.0, {"rms_px": 0.4})
    bad = got["C3-bad"]
    assert bad.state == "failed" and bad.error == "cameras cam02 failed" and bad.done_at is None
    assert cat.calibration_toml(db, "C3-bad") == "[bad]"
    job = cat.lease_job(db, "w1")
    assert job is not None and job.id == 1 and job.trial_id == tid and job.calibration_id is None
    started = cals.start_board_recording(db, recording_path_for=lambda c: f"/d/{c}.mcap")
    cals.queue_calibration(db, started.id, frames=40)
    assert cat.lease_job(db, "w2", kinds=("calibrate",)).calibration_id == started.id
    recording = cals.start_board_recording(db, recording_path_for=lambda c: f"/d/{c}.mcap")
    with pytest.raises(cals.CalibrationBusy, match=recording.id):  # one recording at a time still
        cals.start_board_recording(db, recording_path_for=lambda c: f"/d/{c}.mcap")
    db.close()
    again = cat.open_catalog(path)
    assert cat.schema_version(again) == SCHEMA_VERSION and len(cals.list_calibrations(again)) == 5
    tables = set(inspect(again.engine).get_table_names())
    assert "calibration_runs" not in tables and "jobs_v1" not in tables and "jobs" in tables
    again.close()


def test_a_failed_upgrade_leaves_the_file_as_it_was(v1):
    path, _ = v1
    raw_sql(path, "CREATE TABLE jobs_v1 (x INTEGER)")  # the upgrade's own scratch name is taken
    with pytest.raises(Exception, match="jobs_v1"):
        cat.open_catalog(path)
    assert _version(path) == "1"
    assert raw_sql(path, "SELECT COUNT(*) FROM calibration_runs")[0][0] == 2


def _shape(con: sqlite3.Connection, table: str) -> tuple[list, list]:
    """(columns as (name, type, not null, default, primary key), indexes as (name, columns)) of ``table``."""
    columns = [tuple(r[1:]) for r in con.execute(f"PRAGMA table_info({table})")]
    indexes = sorted((name, [r[2] for r in con.execute(f"PRAGMA index_info({name})")])
                     for _, name, *_ in con.execute(f"PRAGMA index_list({table})"))
    return columns, indexes


@pytest.mark.parametrize("backend", ["sqlite"])  # the frozen DDL's shape, read with SQLite's PRAGMAs
def test_the_version_2_step_builds_the_frozen_jobs_table_whatever_the_model_says_today(v1, monkeypatch):
    """The v1 -> v2 step makes exactly the jobs table its own DDL names; a column added to the ORM model
    later does not leak into what an old catalog migrates to. The later model is a copy of the table with
    the column, put in the model's place for the step only: the shared model is never altered."""
    from gaitcap.services.catalog import migrations
    from gaitcap.services.catalog.models import Job
    from sqlalchemy import Column, Integer, MetaData, create_engine

    path, tid = v1
    today = Job.__table__
    later = today.to_metadata(MetaData())  # the model after a change made after v2
    later.append_column(Column("priority", Integer, nullable=False, server_default="0"))
    engine = create_engine(f"sqlite:///{path}")
    try:
        with monkeypatch.context() as patch, engine.begin() as conn:
            patch.setattr(Job, "__table__", later)
            migrations.STEPS[1](conn)
    finally:
        engine.dispose()
    assert Job.__table__ is today and "priority" not in today.c
    frozen = sqlite3.connect(":memory:")
    frozen.executescript("CREATE TABLE trials (id VARCHAR(64) PRIMARY KEY); "
                         "CREATE TABLE calibrations (id VARCHAR(64) PRIMARY KEY);" + migrations.JOBS_V2_DDL)
    with sqlite3.connect(path) as con:
        got = _shape(con, "jobs")
        rows = con.execute("SELECT id, trial_id, calibration_id, kind, state FROM jobs").fetchall()
    assert got == _shape(frozen, "jobs")
    assert "priority" not in [c[0] for c in got[0]]
    assert [c[0] for c in got[0]] == ["id", "trial_id", "calibration_id", "kind", "state", "attempts", "max_attempts",
                                       "worker_id", "lease_expires_at", "created_at", "started_at", "finished_at",
                                       "error"]
    assert rows == [(1, tid, None, "process", "queued")]
