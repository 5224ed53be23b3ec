"""Request and response bodies of the REST API (pydantic)."""

from __future__ import annotations

import datetime as dt
from typing import Annotated, Literal

from gaitcap.services.catalog.ids import ID_PATTERN
from pydantic import BaseModel, ConfigDict, Field

STATE_WORDS = {
    "recording": "Recording",
    "stopping": "Saving the recording",
    "interrupted": "Recorder lost: recovering the recording",
    "recovered": "Recovered after a recorder crash, waiting for processing",
    "recorded": "Recorded, waiting for processing",
    "processing": "Processing",
    "done": "Done",
    "done_with_warnings": "Done, with warnings",
    "failed": "Failed",
}


class StartTrial(BaseModel):
    """Start recording a trial of ``subject_id`` (pseudonymous id, never a name) in ``session``."""

    model_config = ConfigDict(extra="forbid")
    subject_id: str = Field(pattern=ID_PATTERN, description="Pseudonymous subject id, e.g. P0042")
    session: str = Field(default_factory=lambda: dt.date.today().isoformat(), pattern=ID_PATTERN,
                         description="Session (visit) label; default today's date")
    override_rig_check: bool = Field(default=False, description="Record although the rig check refused "
                                     "(cameras down or far below the frame rate); audited, a warning of the trial")


class TrialOut(BaseModel):
    id: str
    subject_id: str
    session: str
    state: str
    state_text: str
    created_at: float = Field(description="UNIX time, s")
    started_at: float | None
    stopped_at: float | None
    duration_s: float | None
    stage: str
    progress: float = Field(description="Processing progress in [0, 1]")
    error: str
    results: list[str] = Field(default_factory=list, description="Result stages available")
    warnings: list[str] = Field(default_factory=list, description="Data-quality warnings in plain words "
                                "(recovery, rig override, cameras, sync, coverage, reprojection), most important first")
    voided: bool = Field(default=False, description="Marked void (kept, left out of trends and comparisons)")
    void_reason: str = Field(default="", description="Why it was marked void (empty when not void)")
    room: str = Field(default="", description="The capture room it was recorded in ('' the default room)")


class CameraOut(BaseModel):
    name: str
    fps: float
    healthy: bool
    status: str
    age_s: float


class GaitOut(BaseModel):
    trial_id: str
    stage: str
    method: str
    elapsed_s: float = Field(description="Processing time of this stage, s")
    summary: dict[str, dict]
    shown: dict[str, dict] = Field(default_factory=dict, description="The summary's mean and SD as the page shows "
                                   "them (text; the one rounding rule of the page, print and PDF report)")
    steps: list[dict]
    quality: dict
    downloads: dict[str, str]
    warnings: list[str] = Field(default_factory=list, description="The trial's data-quality warnings, plain words")
    sides: dict[str, dict] = Field(default_factory=dict, description="Per parameter (units in the name): left, "
                                   "right, all ({n, mean, sd, cv_pct}) and symmetry_index_pct, over the steady steps")
    analysis_warnings: list[str] = Field(default_factory=list, description="The gait analysis's notes (turns, "
                                         "gaps, steps left out), plain words")
    voided: bool = Field(default=False, description="Marked void: not for clinical use")
    void_reason: str = Field(default="", description="Why it was marked void (empty when not void)")
    findings: dict = Field(default_factory=dict, description="What this stage's report says of its numbers: "
                           "findings (only those that hold over enough counted steps a side and whichever step is "
                           "left out; the preliminary stage's begin 'Preliminary:'), withheld (side differences "
                           "and values outside a range that do not hold, in words), data_problems, norm_summary")
    consistency: dict = Field(default_factory=dict, description="The consistency rules run on this stage's "
                              "parameters (ok, rules_checked, failures naming parameter, side, values, tolerance)")
    data_quality: dict = Field(default_factory=dict, description="Per camera frames expected / received / lost, "
                               "fps, sync spread (ms), coverage, reprojection error (px), ignored_keypoints (per "
                               "camera: keypoint messages left out, strays, mistimed, unreadable), and the criteria")


class BoardIn(BaseModel):
    """A calibration board, the fields of a board file's ``[board]`` table (docs/calibration.md)."""

    model_config = ConfigDict(extra="forbid")
    kind: Literal["checkerboard", "charuco"]
    squares: tuple[Annotated[int, Field(ge=2, le=100)], Annotated[int, Field(ge=2, le=100)]] = Field(
        description="Squares along x (columns) and y (rows)")
    square_mm: float = Field(gt=0, le=1000, description="Side of a square, mm")
    marker_mm: float | None = Field(default=None, gt=0, le=1000, description="ChArUco marker side, mm "
                                    "(default 0.75 x square)")
    dictionary: str = Field(default="DICT_4X4_50", pattern=r"^DICT_[A-Z0-9_]+$", description="ChArUco ArUco dictionary")
    inverted: bool | None = Field(default=None, description="ChArUco printed white markers on black (None: try both)")
    legacy_layout: bool | None = Field(default=None, description="ChArUco in OpenCV's pre-4.6 layout (None: try both)")


class BoardRecordingIn(BaseModel):
    """Start a board recording; ``board`` overrides the clinic's board (``gaitcap serve --board-file``)."""

    model_config = ConfigDict(extra="forbid")
    board: BoardIn | None = None
