"""SQLAlchemy 2 tables of the trial catalog. All times are UNIX epoch seconds (float, UTC).

The schema is portable (SQLite by default, PostgreSQL from a URL): no vendor types, JSON kept as text.
``SCHEMA_VERSION`` is stored in ``schema_info``; :mod:`gaitcap.services.catalog.db` refuses a database whose
version differs, so an old file is never silently misread.
"""

from __future__ import annotations

from sqlalchemy import Float, ForeignKey, Index, Integer, String, Text, UniqueConstraint
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column

SCHEMA_VERSION = 6  # 2: one calibration table; jobs of kind "process" (a trial) or "calibrate"; 3: calibrations.board;
# 4: calibration_versions; 5: results keyed by method and parameters, method_results a catalog table; 6: rooms
# (trials.room, the rooms table, a recording slot per room) and trials.state wide enough for done_with_warnings


class Base(DeclarativeBase):
    pass


class SchemaInfo(Base):
    __tablename__ = "schema_info"
    key: Mapped[str] = mapped_column(String(64), primary_key=True)
    value: Mapped[str] = mapped_column(String(256))


class Subject(Base):
    """A patient, known only by a pseudonymous id (no names, no birth dates)."""

    __tablename__ = "subjects"
    id: Mapped[str] = mapped_column(String(64), primary_key=True)
    created_at: Mapped[float] = mapped_column(Float)


class SessionRow(Base):
    """A visit of one subject (several trials)."""

    __tablename__ = "sessions"
    id: Mapped[str] = mapped_column(String(140), primary_key=True)  # "<subject_id>/<label>"
    subject_id: Mapped[str] = mapped_column(ForeignKey("subjects.id"), index=True)
    created_at: Mapped[float] = mapped_column(Float)


class Calibration(Base):
    """A camera calibration, the one record of every calibration: ``uploaded`` (TOML stored as it came)
    or a ``board recording`` (``recording`` -> ``calibrating`` -> ``done`` | ``failed``; the worker computes
    it as a leased job). ``toml``: aniposelib TOML text (translation in metres), empty until computed;
    ``recording_slot`` is 1 while the board records (one recording at a time); ``done_at``: when it became
    usable (the newest ``done`` one is the active calibration); ``frames``: images in the board recording;
    ``board``: the board filmed, as JSON (the fields of a board file's ``[board]`` table), recorded at the
    start of a board recording; '' when none was given (the default board); ``room``: the capture room whose rig
    it calibrates ('' the default room): each room has its own active calibration and its own board slot."""

    __tablename__ = "calibrations"
    id: Mapped[str] = mapped_column(String(64), primary_key=True)
    created_at: Mapped[float] = mapped_column(Float)
    source: Mapped[str] = mapped_column(String(256), default="")
    toml: Mapped[str] = mapped_column(Text)
    report_json: Mapped[str] = mapped_column(Text, default="{}")
    kind: Mapped[str] = mapped_column(String(32), default="uploaded")  # uploaded | board recording
    state: Mapped[str] = mapped_column(String(16), default="done", index=True)
    recording_slot: Mapped[int | None] = mapped_column(Integer, unique=True, nullable=True)
    done_at: Mapped[float | None] = mapped_column(Float, nullable=True)
    started_at: Mapped[float | None] = mapped_column(Float, nullable=True)
    stopped_at: Mapped[float | None] = mapped_column(Float, nullable=True)
    started_by: Mapped[str] = mapped_column(String(128), default="")
    recording_path: Mapped[str] = mapped_column(String(1024), default="")
    frames: Mapped[int | None] = mapped_column(Integer, nullable=True)
    stage: Mapped[str] = mapped_column(String(64), default="")
    progress: Mapped[float] = mapped_column(Float, default=0.0)
    error: Mapped[str] = mapped_column(Text, default="")
    board: Mapped[str] = mapped_column(Text, default="")
    room: Mapped[str] = mapped_column(String(64), default="", index=True)  # the room whose rig it calibrates


class CalibrationVersion(Base):
    """A calibration made from another one (refined from people): ``calibration_id`` is the new version (a
    calibration record of its own, kept with every other), ``replaces_id`` the one it replaces; ``made_by``:
    how (words: "refine-rig"); ``trials_json``: the trials whose keypoints made it (JSON list of ids or
    paths); ``comparison_json``: per camera, how far it lies from the one it replaces (centre mm, rotation
    deg, focal %); ``applied_at``: when its affected trials were queued again under it (None: not yet)."""

    __tablename__ = "calibration_versions"
    calibration_id: Mapped[str] = mapped_column(ForeignKey("calibrations.id"), primary_key=True)
    replaces_id: Mapped[str | None] = mapped_column(ForeignKey("calibrations.id"), index=True, nullable=True)
    made_by: Mapped[str] = mapped_column(String(64), default="")
    trials_json: Mapped[str] = mapped_column(Text, default="[]")
    comparison_json: Mapped[str] = mapped_column(Text, default="{}")
    created_at: Mapped[float] = mapped_column(Float)
    applied_at: Mapped[float | None] = mapped_column(Float, nullable=True)


class Room(Base):
    """A capture room registered with the catalog (:mod:`gaitcap.services.catalog.rooms`): ``name`` ('' is
    the default room of a one-room clinic), ``slot`` the number its recording trial holds in
    ``trials.recording_slot`` (the default room's is 1), ``host`` where its stack runs, ``rig_json`` its rig
    state as its API last wrote it (cameras, recording trial; JSON), ``seen_at`` when."""

    __tablename__ = "rooms"
    name: Mapped[str] = mapped_column(String(64), primary_key=True)
    slot: Mapped[int] = mapped_column(Integer, unique=True)
    host: Mapped[str] = mapped_column(String(256), default="")
    registered_at: Mapped[float] = mapped_column(Float)
    seen_at: Mapped[float] = mapped_column(Float)
    rig_json: Mapped[str] = mapped_column(Text, default="{}")


class Trial(Base):
    """One walking trial, recorded in ``room`` ('' the default room). ``recording_slot`` is the room's slot
    while recording and NULL otherwise: the unique constraint makes "only one trial records at a time in a
    room" atomic across API processes and hosts."""

    __tablename__ = "trials"
    id: Mapped[str] = mapped_column(String(64), primary_key=True)
    session_id: Mapped[str] = mapped_column(ForeignKey("sessions.id"), index=True)
    subject_id: Mapped[str] = mapped_column(ForeignKey("subjects.id"), index=True)
    state: Mapped[str] = mapped_column(String(32), index=True)
    room: Mapped[str] = mapped_column(String(64), default="", index=True)
    recording_slot: Mapped[int | None] = mapped_column(Integer, unique=True, nullable=True)
    created_at: Mapped[float] = mapped_column(Float, index=True)  # the newest trials first, without a sort
    updated_at: Mapped[float] = mapped_column(Float)
    started_at: Mapped[float | None] = mapped_column(Float, nullable=True)
    stopped_at: Mapped[float | None] = mapped_column(Float, nullable=True)
    recording_path: Mapped[str] = mapped_column(String(1024), default="")
    calibration_id: Mapped[str | None] = mapped_column(ForeignKey("calibrations.id"), nullable=True)
    stage: Mapped[str] = mapped_column(String(64), default="")
    progress: Mapped[float] = mapped_column(Float, default=0.0)
    error: Mapped[str] = mapped_column(Text, default="")
    notes: Mapped[str] = mapped_column(Text, default="")


class TrialQuality(Base):
    """A trial's data-quality record: JSON sections written as the trial goes (``recorder``: the
    recorder's summary at Stop; ``recovery``: what a crash recovery kept and lost; ``start``: a Start
    that overrode a refused rig check; ``processing``: the worker's measures and warnings)."""

    __tablename__ = "trial_quality"
    trial_id: Mapped[str] = mapped_column(ForeignKey("trials.id"), primary_key=True)
    updated_at: Mapped[float] = mapped_column(Float)
    sections_json: Mapped[str] = mapped_column(Text, default="{}")


class Job(Base):
    """Work for a worker, held under a lease: a worker that dies stops renewing and, once
    ``lease_expires_at`` has passed, another worker takes the job over. ``kind`` says what it works on:
    ``process`` a trial (``trial_id``), ``calibrate`` a board recording (``calibration_id``)."""

    __tablename__ = "jobs"
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    trial_id: Mapped[str | None] = mapped_column(ForeignKey("trials.id"), index=True, nullable=True)
    calibration_id: Mapped[str | None] = mapped_column(ForeignKey("calibrations.id"), index=True, nullable=True)
    kind: Mapped[str] = mapped_column(String(32), default="process")
    state: Mapped[str] = mapped_column(String(16), index=True)  # queued | running | done | failed
    attempts: Mapped[int] = mapped_column(Integer, default=0)
    max_attempts: Mapped[int] = mapped_column(Integer, default=3)
    worker_id: Mapped[str] = mapped_column(String(128), default="")
    lease_expires_at: Mapped[float] = mapped_column(Float, default=0.0)
    created_at: Mapped[float] = mapped_column(Float)
    started_at: Mapped[float | None] = mapped_column(Float, nullable=True)
    finished_at: Mapped[float | None] = mapped_column(Float, nullable=True)
    error: Mapped[str] = mapped_column(Text, default="")


class Result(Base):
    """Gait metrics of one processing stage (``preliminary`` or ``refined``) of a trial. ``method``: the
    method in words; ``method_name`` (a :data:`gaitcap.reconstruction.methods.METHODS` name) and
    ``params_key`` (:func:`gaitcap.services.catalog.method_keys.params_key` of its config): the key research
    reads it under (:mod:`gaitcap.services.catalog.method_results`); '' on rows stored before schema 5."""

    __tablename__ = "results"
    __table_args__ = (UniqueConstraint("trial_id", "stage"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    trial_id: Mapped[str] = mapped_column(ForeignKey("trials.id"), index=True)
    stage: Mapped[str] = mapped_column(String(16))
    method: Mapped[str] = mapped_column(String(128), default="")
    method_name: Mapped[str] = mapped_column(String(32), default="")
    params_key: Mapped[str] = mapped_column(String(32), default="")
    created_at: Mapped[float] = mapped_column(Float)
    elapsed_s: Mapped[float] = mapped_column(Float, default=0.0)
    report_json: Mapped[str] = mapped_column(Text, default="{}")
    quality_json: Mapped[str] = mapped_column(Text, default="{}")
    artifacts_json: Mapped[str] = mapped_column(Text, default="{}")


class Step(Base):
    """One step of a result: side, time and the step's parameters (JSON, units in the keys)."""

    __tablename__ = "steps"
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    result_id: Mapped[int] = mapped_column(ForeignKey("results.id", ondelete="CASCADE"), index=True)
    index: Mapped[int] = mapped_column(Integer)
    side: Mapped[str] = mapped_column(String(8))
    time_s: Mapped[float] = mapped_column(Float)
    values_json: Mapped[str] = mapped_column(Text)


class Summary(Base):
    """One summary parameter of a result (e.g. ``step_length_mm`` mean and SD over the steps)."""

    __tablename__ = "summaries"
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    result_id: Mapped[int] = mapped_column(ForeignKey("results.id", ondelete="CASCADE"), index=True)
    name: Mapped[str] = mapped_column(String(64))
    value: Mapped[float | None] = mapped_column(Float, nullable=True)
    sd: Mapped[float | None] = mapped_column(Float, nullable=True)
    unit: Mapped[str] = mapped_column(String(16), default="")


class MethodResultRow(Base):
    """A research result of one trial under one method config, keyed by (trial, method, params_key) and
    written once (the first write wins): metrics, gait summary, residuals against a reference, files (JSON)."""

    __tablename__ = "method_results"
    __table_args__ = (UniqueConstraint("trial_id", "method", "params_key"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    trial_id: Mapped[str] = mapped_column(String(64), index=True)
    method: Mapped[str] = mapped_column(String(32))
    params_key: Mapped[str] = mapped_column(String(32), index=True)
    spec_json: Mapped[str] = mapped_column(Text)
    config_json: Mapped[str] = mapped_column(Text)
    status: Mapped[str] = mapped_column(String(16))  # ok | failed
    error: Mapped[str] = mapped_column(Text, default="")
    created_at: Mapped[float] = mapped_column(Float)
    elapsed_s: Mapped[float] = mapped_column(Float, default=0.0)
    worker: Mapped[str] = mapped_column(String(128), default="")
    skeleton: Mapped[str] = mapped_column(String(32), default="")
    metrics_json: Mapped[str] = mapped_column(Text, default="{}")
    gait_json: Mapped[str] = mapped_column(Text, default="{}")
    residuals_json: Mapped[str] = mapped_column(Text, default="{}")
    artifacts_json: Mapped[str] = mapped_column(Text, default="{}")


class AuditEntry(Base):
    """Who did what to which trial (start, stop, view, download, ...)."""

    __tablename__ = "audit_log"
    __table_args__ = (Index("ix_audit_trial_time", "trial_id", "at"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    at: Mapped[float] = mapped_column(Float)
    actor: Mapped[str] = mapped_column(String(128))
    action: Mapped[str] = mapped_column(String(32))
    trial_id: Mapped[str | None] = mapped_column(String(64), nullable=True)
    detail: Mapped[str] = mapped_column(Text, default="")


class PatientDetails(Base):
    """What the clinic records about a patient besides the pseudonym: sex and birth year (for the
    normative comparison by age decade and sex; both optional) and free notes."""

    __tablename__ = "patient_details"
    subject_id: Mapped[str] = mapped_column(ForeignKey("subjects.id"), primary_key=True)
    sex: Mapped[str] = mapped_column(String(16), default="")  # "female" | "male" | ""
    birth_year: Mapped[int | None] = mapped_column(Integer, nullable=True)
    notes: Mapped[str] = mapped_column(Text, default="")
    updated_at: Mapped[float] = mapped_column(Float)


class TrialDetails(Base):
    """The clinician's fields of a trial (filled at Start or after; corrections are audited) and its
    void mark: a voided trial stays in the chart with the reason but is left out of the history."""

    __tablename__ = "trial_details"
    trial_id: Mapped[str] = mapped_column(ForeignKey("trials.id"), primary_key=True)
    operator: Mapped[str] = mapped_column(String(128), default="")
    walking_aid: Mapped[str] = mapped_column(String(128), default="")
    assistance: Mapped[str] = mapped_column(String(128), default="")
    footwear: Mapped[str] = mapped_column(String(128), default="")
    notes: Mapped[str] = mapped_column(Text, default="")
    voided_at: Mapped[float | None] = mapped_column(Float, nullable=True)
    voided_by: Mapped[str] = mapped_column(String(128), default="")
    void_reason: Mapped[str] = mapped_column(Text, default="")
    updated_at: Mapped[float] = mapped_column(Float)
