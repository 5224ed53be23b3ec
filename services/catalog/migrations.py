"""Bringing a catalog written by an older gaitcap up to :data:`SCHEMA_VERSION` when it is opened.

Each step moves one version up in one transaction (a failure leaves the database as it was), on SQLite and
on PostgreSQL (transactional DDL there too). The frozen DDL of a version is written once, in SQLite's words;
:func:`portable` gives PostgreSQL's (an integer key that numbers itself is ``SERIAL`` there).
"""

from __future__ import annotations

import logging

from sqlalchemy import Connection, inspect, text

log = logging.getLogger(__name__)

_CALIBRATION_COLUMNS = (  # columns the one calibration record gained in version 2
    "kind VARCHAR(32) NOT NULL DEFAULT 'uploaded'", "state VARCHAR(16) NOT NULL DEFAULT 'done'",
    "recording_slot INTEGER", "done_at FLOAT", "started_at FLOAT", "stopped_at FLOAT",
    "started_by VARCHAR(128) NOT NULL DEFAULT ''", "recording_path VARCHAR(1024) NOT NULL DEFAULT ''",
    "frames INTEGER", "stage VARCHAR(64) NOT NULL DEFAULT ''", "progress FLOAT NOT NULL DEFAULT 0",
    "error TEXT NOT NULL DEFAULT ''",
)
AUTO_ID = "id INTEGER NOT NULL"  # a table's own row number in the frozen DDL (SQLite numbers it itself)
_PORTABLE = {"postgresql": {AUTO_ID: "id SERIAL NOT NULL"}}  # dialect -> frozen words -> its words


def portable(ddl: str, dialect: str) -> str:
    """The frozen DDL ``ddl`` (SQLite's words) as ``dialect`` (a SQLAlchemy dialect name) needs it."""
    for frozen, theirs in _PORTABLE.get(dialect, {}).items():
        ddl = ddl.replace(frozen, theirs)
    return ddl


def _run_ddl(conn: Connection, ddl: str) -> None:
    for statement in portable(ddl, conn.dialect.name).split(";"):
        if statement.strip():
            conn.exec_driver_sql(statement)


def _renumber(conn: Connection, table: str) -> None:
    """PostgreSQL: the table's id sequence goes on after the rows copied in with their ids."""
    if conn.dialect.name == "postgresql":
        conn.exec_driver_sql(f"SELECT setval(pg_get_serial_sequence('{table}', 'id'), "
                             f"COALESCE((SELECT MAX(id) FROM {table}), 0) + 1, false)")


_RUN_FIELDS = ("state", "recording_slot", "started_at", "stopped_at", "started_by", "recording_path", "stage",
               "progress", "error")


def _one_calibration_table(conn: Connection) -> None:
    """calibration_runs folded into calibrations: a run that passed updates its calibration (same id), a
    failed or unfinished one becomes a calibration of its own; ``done_at`` is when it became usable."""
    for column in _CALIBRATION_COLUMNS:
        conn.exec_driver_sql(f"ALTER TABLE calibrations ADD COLUMN {column}")
    conn.exec_driver_sql("UPDATE calibrations SET done_at = created_at")
    conn.exec_driver_sql("CREATE UNIQUE INDEX ix_calibrations_recording_slot ON calibrations (recording_slot)")
    conn.exec_driver_sql("CREATE INDEX ix_calibrations_state ON calibrations (state)")
    runs = conn.execute(text("SELECT * FROM calibration_runs")).mappings().all()
    for run in runs:
        values = {k: run[k] for k in _RUN_FIELDS} | {"id": run["id"], "created_at": run["created_at"],
                                                     "toml": run["toml"], "report_json": run["report_json"]}
        exists = conn.execute(text("SELECT 1 FROM calibrations WHERE id = :id"), {"id": run["id"]}).first()
        columns = ("created_at", "toml", "report_json", *_RUN_FIELDS)
        if exists:
            sets = ", ".join(f"{c} = :{c}" for c in columns)
            conn.execute(text(f"UPDATE calibrations SET kind = 'board recording', {sets} WHERE id = :id"), values)
        else:
            names = ", ".join(("id", *columns))
            conn.execute(text(f"INSERT INTO calibrations (kind, source, done_at, {names}) VALUES ('board recording', "
                              f"'board recording by ' || :started_by, NULL, {', '.join(':' + c for c in ('id', *columns))})"),
                         values)
    conn.exec_driver_sql("DROP TABLE calibration_runs")
    log.info("catalog: %d board recordings moved into calibrations", len(runs))


JOBS_V2_DDL = """
CREATE TABLE jobs (
    id INTEGER NOT NULL,
    trial_id VARCHAR(64),
    calibration_id VARCHAR(64),
    kind VARCHAR(32) NOT NULL,
    state VARCHAR(16) NOT NULL,
    attempts INTEGER NOT NULL,
    max_attempts INTEGER NOT NULL,
    worker_id VARCHAR(128) NOT NULL,
    lease_expires_at FLOAT NOT NULL,
    created_at FLOAT NOT NULL,
    started_at FLOAT,
    finished_at FLOAT,
    error TEXT NOT NULL,
    PRIMARY KEY (id),
    FOREIGN KEY(trial_id) REFERENCES trials (id),
    FOREIGN KEY(calibration_id) REFERENCES calibrations (id)
);
CREATE INDEX ix_jobs_calibration_id ON jobs (calibration_id);
CREATE INDEX ix_jobs_trial_id ON jobs (trial_id);
CREATE INDEX ix_jobs_state ON jobs (state);
"""  # the jobs table of schema version 2, frozen: a later model change never alters what v1 migrates to


def _jobs_of_any_kind(conn: Connection) -> None:
    """jobs.trial_id nullable and jobs.calibration_id added: the table is rebuilt (SQLite cannot drop NOT NULL)."""
    conn.exec_driver_sql("ALTER TABLE jobs RENAME TO jobs_v1")
    for index in ("ix_jobs_trial_id", "ix_jobs_state"):
        conn.exec_driver_sql(f"DROP INDEX IF EXISTS {index}")
    if conn.dialect.name == "postgresql":  # the key's index keeps its name across the rename: free it
        conn.exec_driver_sql("ALTER INDEX IF EXISTS jobs_pkey RENAME TO jobs_v1_pkey")
    _run_ddl(conn, JOBS_V2_DDL)
    names = ("id, trial_id, kind, state, attempts, max_attempts, worker_id, lease_expires_at, created_at, "
             "started_at, finished_at, error")
    conn.exec_driver_sql(f"INSERT INTO jobs ({names}) SELECT {names} FROM jobs_v1")
    conn.exec_driver_sql("DROP TABLE jobs_v1")
    _renumber(conn, "jobs")


def _v1_to_v2(conn: Connection) -> None:
    _one_calibration_table(conn)
    _jobs_of_any_kind(conn)


def _v2_to_v3(conn: Connection) -> None:
    """calibrations.board: the board filmed (JSON); '' on older records (they used the default board)."""
    conn.exec_driver_sql("ALTER TABLE calibrations ADD COLUMN board TEXT NOT NULL DEFAULT ''")


VERSIONS_V4_DDL = """
CREATE TABLE IF NOT EXISTS calibration_versions (
    calibration_id VARCHAR(64) NOT NULL,
    replaces_id VARCHAR(64),
    made_by VARCHAR(64) NOT NULL,
    trials_json TEXT NOT NULL,
    comparison_json TEXT NOT NULL,
    created_at FLOAT NOT NULL,
    applied_at FLOAT,
    PRIMARY KEY (calibration_id),
    FOREIGN KEY(calibration_id) REFERENCES calibrations (id),
    FOREIGN KEY(replaces_id) REFERENCES calibrations (id)
);
CREATE INDEX IF NOT EXISTS ix_calibration_versions_replaces_id ON calibration_versions (replaces_id);
"""  # the table of schema version 4, frozen


def _v3_to_v4(conn: Connection) -> None:
    """calibration_versions: which calibration a refined one replaces (older catalogs have none)."""
    _run_ddl(conn, VERSIONS_V4_DDL)


METHOD_RESULTS_V5_DDL = """
CREATE TABLE IF NOT EXISTS method_results (
    id INTEGER NOT NULL,
    trial_id VARCHAR(64) NOT NULL,
    method VARCHAR(32) NOT NULL,
    params_key VARCHAR(32) NOT NULL,
    spec_json TEXT NOT NULL,
    config_json TEXT NOT NULL,
    status VARCHAR(16) NOT NULL,
    error TEXT NOT NULL,
    created_at FLOAT NOT NULL,
    elapsed_s FLOAT NOT NULL,
    worker VARCHAR(128) NOT NULL,
    skeleton VARCHAR(32) NOT NULL,
    metrics_json TEXT NOT NULL,
    gait_json TEXT NOT NULL,
    residuals_json TEXT NOT NULL,
    artifacts_json TEXT NOT NULL,
    PRIMARY KEY (id),
    UNIQUE (trial_id, method, params_key)
);
CREATE INDEX IF NOT EXISTS ix_method_results_trial_id ON method_results (trial_id);
CREATE INDEX IF NOT EXISTS ix_method_results_params_key ON method_results (params_key);
"""  # the table of schema version 5, frozen (as research reprocessing created it before: its rows are kept)


def _v4_to_v5(conn: Connection) -> None:
    """One results store: ``results`` keyed by method and parameters (older rows: '', their parameters were
    not recorded) and ``method_results`` a catalog table (created here where research never ran)."""
    present = {column["name"] for column in inspect(conn).get_columns("results")}
    for column in ("method_name VARCHAR(32) NOT NULL DEFAULT ''", "params_key VARCHAR(32) NOT NULL DEFAULT ''"):
        if column.split()[0] not in present:  # a catalog made by this gaitcap and marked older has them
            conn.exec_driver_sql(f"ALTER TABLE results ADD COLUMN {column}")
    _run_ddl(conn, METHOD_RESULTS_V5_DDL)


ROOMS_V6_DDL = """
CREATE TABLE IF NOT EXISTS rooms (
    name VARCHAR(64) NOT NULL,
    slot INTEGER NOT NULL,
    host VARCHAR(256) NOT NULL,
    registered_at FLOAT NOT NULL,
    seen_at FLOAT NOT NULL,
    rig_json TEXT NOT NULL,
    PRIMARY KEY (name),
    UNIQUE (slot)
);
CREATE INDEX IF NOT EXISTS ix_trials_room ON trials (room);
CREATE INDEX IF NOT EXISTS ix_calibrations_room ON calibrations (room);
CREATE INDEX IF NOT EXISTS ix_trials_created_at ON trials (created_at)
"""  # the table of schema version 6, frozen


def _v5_to_v6(conn: Connection) -> None:
    """Rooms: ``trials.room`` and ``calibrations.room`` ('' on older rows: the default room, whose recording slot
    stays 1) and the rooms table; ``trials.state`` 32 wide (PostgreSQL enforces the width; SQLite never did)."""
    for table in ("trials", "calibrations"):
        if "room" not in {column["name"] for column in inspect(conn).get_columns(table)}:  # (made by this gaitcap)
            conn.exec_driver_sql(f"ALTER TABLE {table} ADD COLUMN room VARCHAR(64) NOT NULL DEFAULT ''")
    if conn.dialect.name == "postgresql":
        conn.exec_driver_sql("ALTER TABLE trials ALTER COLUMN state TYPE VARCHAR(32)")
    _run_ddl(conn, ROOMS_V6_DDL)


MIGRATES = frozenset({"sqlite", "postgresql"})  # the databases the steps are tested on
STEPS = {1: _v1_to_v2, 2: _v2_to_v3, 3: _v3_to_v4, 4: _v4_to_v5, 5: _v5_to_v6}  # from version -> the step to the next


def migration_problem(dialect: str, version: int, target: int) -> str | None:
    """Why a catalog of ``version`` cannot be brought to ``target`` here, or None when it can."""
    missing = [v for v in range(version, target) if v not in STEPS]
    if version > target or missing:
        return f"schema version {version}, this gaitcap expects {target} and knows no way from one to the other"
    if dialect not in MIGRATES:
        return (f"schema version {version}, this gaitcap expects {target}: the upgrade runs on "
                f"{' and '.join(sorted(MIGRATES))} only (steps {list(range(version, target))} in "
                "gaitcap.services.catalog.migrations)")
    return None
