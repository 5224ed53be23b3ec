"""Several people in view: who was tracked in a trial, and choosing the patient (from the list, or by a
click on a camera image); a new choice sends the trial back through processing."""

from __future__ import annotations

import logging

from fastapi import APIRouter, Depends, HTTPException, Request, Response
from gaitcap.api.auth import require_user
from gaitcap.api.deps import catalog_of, checked_trial_id
from gaitcap.services import catalog as cat
from gaitcap.services.processing.artifacts import TrialFiles, trial_files
from gaitcap.services.processing.people import (
    PatientChoice,
    read_choice,
    read_people,
    recorded_still,
    track_at_click,
    write_choice,
)
from pydantic import BaseModel, ConfigDict, Field, model_validator

log = logging.getLogger(__name__)
router = APIRouter(tags=["people"])
CHOOSABLE_STATES = ("done", "done_with_warnings", "failed")


class PatientIn(BaseModel):
    """Either ``track_id`` (from ``GET /trials/{id}/people``) or a click: ``camera``, ``frame`` (0 = the
    recording's first frame), ``x_px``, ``y_px`` on that camera's image."""

    model_config = ConfigDict(extra="forbid")
    track_id: int | None = Field(default=None, ge=0, description="The patient's track id")
    camera: str | None = Field(default=None, min_length=1, max_length=64, description="Camera clicked on")
    frame: int | None = Field(default=None, ge=0, description="Frame index of the image clicked on")
    x_px: float | None = Field(default=None, allow_inf_nan=False, description="Click, px from the left")
    y_px: float | None = Field(default=None, allow_inf_nan=False, description="Click, px from the top")

    @model_validator(mode="after")
    def _one_form(self) -> PatientIn:
        click = {"camera": self.camera, "frame": self.frame, "x_px": self.x_px, "y_px": self.y_px}
        given = [k for k, v in click.items() if v is not None]
        if self.track_id is not None and given:
            raise ValueError(f"give either track_id or a click (camera, frame, x_px, y_px), not both ({given[0]})")
        if self.track_id is None and len(given) != 4:
            missing = [k for k, v in click.items() if v is None]
            raise ValueError(f"track_id or a click: missing {', '.join(missing)}" if given else
                             "track_id: required (or a click: camera, frame, x_px, y_px)")
        return self


def _files(request: Request, trial_id: str) -> tuple[cat.TrialInfo, TrialFiles]:
    trial_id = checked_trial_id(trial_id)
    try:
        trial = cat.get_trial(catalog_of(request), trial_id)
    except cat.TrialNotFound as exc:
        raise HTTPException(status_code=404, detail=str(exc)) from None
    return trial, trial_files(request.app.state.settings.data_dir, trial_id, trial.recording_path)


def _people_out(trial: cat.TrialInfo, files: TrialFiles) -> dict:
    people = read_people(files) or {}
    patient = people.get("patient_track_id")
    choice = read_choice(files)
    return {
        "trial_id": trial.id, "state": trial.state,
        "patient_track_id": patient, "chosen_by": people.get("chosen_by"),
        "pending_choice": choice.track_id if choice is not None and choice.track_id != patient else None,
        "cameras": people.get("cameras", []), "frames": people.get("frames", 0),
        "busiest_frame": people.get("busiest_frame"), "image_sizes_px": people.get("image_sizes_px", {}),
        "boxes_px": people.get("boxes_px", {}),
        "people": [{**p, "is_patient": p["track_id"] == patient} for p in people.get("people", [])],
    }


@router.get("/trials/{trial_id}/people", summary="People tracked in a trial and which one is the patient")
def people(trial_id: str, request: Request, user: str = Depends(require_user)) -> dict:
    """An empty ``people`` list when one person was in view (or the trial is not processed yet)."""
    trial, files = _files(request, trial_id)
    cat.audit(catalog_of(request), actor=user, action="view", trial_id=trial.id, detail="people")
    return _people_out(trial, files)


def _chosen_track(body: PatientIn, files: TrialFiles, people: dict) -> tuple[int, str]:
    """The track id the body names and how it was chosen (words); 404 naming an unknown track or camera."""
    ids = [p["track_id"] for p in people["people"]]
    if body.track_id is not None:
        if body.track_id not in ids:
            raise HTTPException(status_code=404, detail=f"track_id: no person with track {body.track_id} "
                                                        f"in this trial (tracks: {ids})")
        return body.track_id, "chosen from the list"
    if body.camera not in people["cameras"]:
        raise HTTPException(status_code=404, detail=f"camera: {body.camera!r} is not in this trial "
                                                    f"(cameras: {people['cameras']})")
    if body.frame >= people["frames"]:
        raise HTTPException(status_code=422, detail=f"frame: {body.frame} is outside 0..{people['frames'] - 1}")
    try:
        track = track_at_click(files, camera=body.camera, frame=body.frame, x_px=body.x_px, y_px=body.y_px)
    except (LookupError, ValueError) as exc:
        raise HTTPException(status_code=404, detail=f"x_px, y_px: {exc}") from None
    return track, f"click on camera {body.camera} frame {body.frame} at ({body.x_px:.0f}, {body.y_px:.0f}) px"


@router.post("/trials/{trial_id}/patient", summary="Choose the patient among the people in view; reprocess")
def choose_patient(trial_id: str, body: PatientIn, request: Request, user: str = Depends(require_user)) -> dict:
    db = catalog_of(request)
    trial, files = _files(request, trial_id)
    if trial.state not in CHOOSABLE_STATES:
        raise HTTPException(status_code=409, detail=f"trial {trial.id} is {trial.state}: the patient can be "
                                                    "chosen once processing has finished")
    people = read_people(files)
    if not people or not people.get("people"):
        raise HTTPException(status_code=409, detail=f"trial {trial.id}: only one person was in view, "
                                                    "there is nobody else to choose")
    track, how = _chosen_track(body, files, people)
    write_choice(files, PatientChoice(track_id=track, chosen_by=user, how=how))
    try:
        trial = cat.set_state(db, trial.id, "recorded", expect=trial.state, stage="waiting for a worker",
                              progress=0.0, error="")
    except cat.IllegalTransition as exc:
        raise HTTPException(status_code=409, detail=str(exc)) from None
    cleared = cat.clear_results(db, trial.id)  # the old numbers are someone else's: never shown as current
    cat.enqueue_job(db, trial.id)
    log.info("trial %s: %d old results cleared", trial.id, cleared)
    cat.audit(db, actor=user, action="choose patient", trial_id=trial.id, detail=f"track {track} ({how})")
    log.info("trial %s: %s chose track %d as the patient (%s); processing queued", trial.id, user, track, how)
    return _people_out(trial, files)


@router.get("/trials/{trial_id}/still/{camera}.jpg", summary="A camera's recorded image of one frame (to click on)")
def still(trial_id: str, camera: str, frame: int, request: Request, user: str = Depends(require_user)) -> Response:
    """``frame``: 0 = the recording's first frame, as in ``POST /trials/{id}/patient``."""
    trial, files = _files(request, trial_id)
    people = read_people(files)
    if not people:
        raise HTTPException(status_code=404, detail=f"trial {trial.id}: no people tracked (one person in view)")
    if camera not in people["cameras"]:
        raise HTTPException(status_code=404, detail=f"camera: {camera!r} is not in this trial")
    if not 0 <= frame < people["frames"]:
        raise HTTPException(status_code=422, detail=f"frame: {frame} is outside 0..{people['frames'] - 1}")
    jpeg = recorded_still(files, camera=camera, frame_id=people.get("first_frame_id", 0) + frame)
    if jpeg is None:
        raise HTTPException(status_code=404, detail=f"camera {camera}: no image recorded for frame {frame}")
    cat.audit(catalog_of(request), actor=user, action="view", trial_id=trial.id, detail=f"still {camera} {frame}")
    return Response(jpeg, media_type="image/jpeg")
