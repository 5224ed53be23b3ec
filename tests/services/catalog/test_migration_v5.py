"""A catalog written by schema version 4 (research's ``method_results`` a table of its own, clinic results
without a method key) opens upgraded to 5: research's rows kept and read under their key, the clinic's old
rows kept (no parameters key: they were stored without one); where research never ran, the table is made."""

from gaitcap.services import catalog as cat
from gaitcap.services.catalog import method_results as store
from gaitcap.services.catalog.migrations import portable
from gaitcap.services.catalog.models import SCHEMA_VERSION
from sqlalchemy import inspect
from sqlalchemy.engine import make_url

from .conftest import raw_sql

V4_METHOD_RESULTS = """
DROP TABLE IF EXISTS method_results;
CREATE TABLE method_results (id INTEGER NOT NULL, trial_id VARCHAR(64) NOT NULL, method VARCHAR(32) NOT NULL,
    params_key VARCHAR(32) NOT NULL, spec_json TEXT NOT NULL, config_json TEXT NOT NULL, status VARCHAR(16) NOT NULL,
    error TEXT NOT NULL, created_at FLOAT NOT NULL, elapsed_s FLOAT NOT NULL, worker VARCHAR(128) NOT NULL,
    skeleton VARCHAR(32) NOT NULL, metrics_json TEXT NOT NULL, gait_json TEXT NOT NULL, residuals_json TEXT NOT NULL,
    artifacts_json TEXT NOT NULL, PRIMARY KEY (id), UNIQUE (trial_id, method, params_key));
CREATE INDEX ix_method_results_trial_id ON method_results (trial_id);
CREATE INDEX ix_method_results_params_key ON method_results (params_key);
INSERT INTO method_results VALUES (1, 'T1', 'robust', '0123456789abcdef', '{"method": "robust"}', '{}', 'ok', '',
    100.0, 2.5, 'host-1', 'halpe26', '{"GC_10": 0.8}', '{"steps": 12, "summary": {}}',
    '{"reference": "walkway"}', '{}');
INSERT INTO method_results VALUES (2, 'T1', 'dlt', 'fedcba9876543210', '{"method": "dlt"}', '{}', 'failed',
    'too few views', 101.0, 0.5, 'host-1', '', '{}', '{}', '{}', '{}');
"""


def _v4(path: str, *, research: bool):
    """A version 4 catalog with trial T1 and its preliminary result; with ``research``, two research rows."""
    db = cat.open_catalog(path)
    cat.start_trial(db, subject_id="P1", session="s1", trial_id="T1", recording_path_for=lambda t: f"/d/{t}.mcap")
    cat.store_result(db, trial_id="T1", stage="preliminary", method="robust triangulation", steps=[],
                     summary={"cadence_steps_per_min": {"mean": 110.0, "unit": "steps/min"}})
    db.close()
    dialect = make_url(path).get_backend_name() if "://" in path else "sqlite"
    raw_sql(path, (portable(V4_METHOD_RESULTS, dialect) if research else "DROP TABLE method_results;")
            + "; ALTER TABLE results DROP COLUMN method_name; ALTER TABLE results DROP COLUMN params_key"
            + "; UPDATE schema_info SET value = '4' WHERE key = 'version'")
    return path


def test_a_version_4_catalog_keeps_research_rows_in_the_one_store(fresh_catalog_url):
    path = _v4(fresh_catalog_url, research=True)
    db = cat.open_catalog(path, create=False)
    assert cat.schema_version(db) == SCHEMA_VERSION == 6
    got = store.get_result(db, "T1", "robust", "0123456789abcdef")
    assert (got.status, got.elapsed_s, got.worker, got.metrics, got.residuals) == (
        "ok", 2.5, "host-1", {"GC_10": 0.8}, {"reference": "walkway"})
    assert got.stage == "" and got.gait["steps"] == 12
    assert store.done_keys(db) == {("T1", "robust", "0123456789abcdef"), ("T1", "dlt", "fedcba9876543210")}
    assert [r.method for r in store.list_results(db)] == ["robust", "dlt"]  # the old clinic row has no key
    assert not store.put_result(db, store.MethodResult("T1", "robust", "0123456789abcdef", {}, "failed"), config={})
    assert store.get_result(db, "T1", "robust", "0123456789abcdef").ok  # the first write still wins
    assert cat.get_result(db, "T1", "preliminary").summary["cadence_steps_per_min"]["mean"] == 110.0
    cat.store_result(db, trial_id="T1", stage="refined", method="implicit trajectory fit", steps=[], summary={},
                     method_name="implicit", params_key="00000000000000aa")
    assert store.get_result(db, "T1", "implicit", "00000000000000aa").stage == "refined"
    db.close()
    again = cat.open_catalog(path)
    assert cat.schema_version(again) == SCHEMA_VERSION and len(store.list_results(again)) == 3
    column = {c["name"]: c for c in inspect(again.engine).get_columns("results")}["params_key"]
    old = raw_sql(path, "SELECT method_name, params_key FROM results WHERE stage = 'preliminary'")[0]
    assert (str(column["type"]), column["nullable"]) == ("VARCHAR(32)", False) and tuple(old) == ("", "")
    assert column["default"].startswith("''")  # '' (SQLite), ''::character varying (PostgreSQL)
    again.close()


def test_a_version_4_catalog_where_research_never_ran_gets_the_table(fresh_catalog_url):
    path = _v4(fresh_catalog_url, research=False)
    db = cat.open_catalog(path, create=False)  # nothing created but by the upgrade
    assert cat.schema_version(db) == SCHEMA_VERSION and store.done_keys(db) == set()
    assert store.put_result(db, store.MethodResult("T1", "dlt", "fedcba9876543210", {}, "ok"), config={})
    assert store.is_done(db, "T1", "dlt", "fedcba9876543210")
    db.close()
