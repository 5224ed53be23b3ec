"""The trial catalog: SQLAlchemy 2 tables and repository functions (SQLite by default, any URL).

Typical use::

    cat = open_catalog("runs/catalog.sqlite")          # or "postgresql+psycopg://..."
    t = start_trial(cat, subject_id="P001", session="visit1")
    set_state(cat, t.id, "recorded"); enqueue_job(cat, t.id)
"""

from gaitcap.services.catalog.audit import entries as audit_entries
from gaitcap.services.catalog.audit import record as audit
from gaitcap.services.catalog.calibrations import (
    CalibrationInfo,
    CalibrationNotFound,
    add_calibration,
    calibration_toml,
    get_calibration,
    latest_calibration,
)
from gaitcap.services.catalog.db import Catalog, SchemaMismatch, database_url, open_catalog, schema_version
from gaitcap.services.catalog.ids import new_trial_id, validate_id
from gaitcap.services.catalog.jobs import (
    JobInfo,
    complete_job,
    enqueue_job,
    fail_job,
    jobs_for_calibration,
    jobs_for_trial,
    lease_job,
    renew_lease,
)
from gaitcap.services.catalog.quality import get_quality, qualities_of, set_quality, warnings_of
from gaitcap.services.catalog.results import (
    ResultInfo,
    add_artifacts,
    best_means_of,
    clear_results,
    get_result,
    stages_available,
    stages_of,
    store_result,
)
from gaitcap.services.catalog.rooms import RoomNotFound, get_room, list_rooms, register_room
from gaitcap.services.catalog.states import FINISHED, PROCESSABLE, IllegalTransition, TrialState
from gaitcap.services.catalog.trials import (
    RecordingBusy,
    TrialInfo,
    TrialNotFound,
    current_recording,
    get_trial,
    list_trials,
    set_progress,
    set_state,
    start_trial,
)

__all__ = [
    "Catalog", "SchemaMismatch", "database_url", "open_catalog", "schema_version",
    "TrialState", "IllegalTransition", "RecordingBusy", "TrialInfo", "TrialNotFound",
    "start_trial", "get_trial", "list_trials", "set_state", "set_progress", "current_recording",
    "JobInfo", "enqueue_job", "lease_job", "renew_lease", "complete_job", "fail_job", "jobs_for_trial",
    "jobs_for_calibration",
    "ResultInfo", "add_artifacts", "best_means_of", "clear_results", "store_result", "get_result",
    "stages_available", "stages_of",
    "CalibrationInfo", "CalibrationNotFound", "add_calibration", "calibration_toml", "get_calibration",
    "latest_calibration",
    "get_quality", "qualities_of", "set_quality", "warnings_of", "FINISHED", "PROCESSABLE",
    "audit", "audit_entries", "new_trial_id", "validate_id",
    "RoomNotFound", "get_room", "list_rooms", "register_room",
]
