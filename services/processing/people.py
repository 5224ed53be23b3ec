"""Several people in view: who is the patient of a trial.

When a recording has more than one person in any camera frame, the worker associates everyone across
cameras and time (:mod:`gaitcap.reconstruction.association`) and picks the patient: the clinician's stored choice
(``patient_choice.json``) when there is one, else automatically (the person who walks the walkway). A
single-person recording takes none of this (the detector's only person is the patient).

Files in the trial folder (:class:`~gaitcap.services.processing.artifacts.TrialFiles`):

- ``people.json`` (worker): ``{"cameras": [...], "frames": T, "first_frame_id": recorder frame id of
  frame 0, "busiest_frame": a frame with the most people in view, "image_sizes_px": {camera: [w, h]},
  "boxes_px": {camera: [{"track_id", "box_px": [x0, y0, x1, y1]}]} (everyone in the busiest frame),
  "patient_track_id": int, "chosen_by": "automatic" | "clinician" | "requested", "people": [{"track_id", "first_s",
  "last_s", "seen_s", "frames", "mean_views", "path_mm", "mean_position_mm"}]}``.
- ``tracks.npz`` (worker): the tracks (which detection is whose), to resolve a click on a camera image.
- ``patient_choice.json`` (API): ``{"track_id": int, "chosen_by": user, "how": words}``.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from gaitcap.acquisition.fileio import atomic_savez, atomic_write_bytes
from gaitcap.reconstruction.association import ManualTrack, PatientSelection, Tracks
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.services.processing.artifacts import TrialFiles

log = logging.getLogger(__name__)
IN_VIEW_CONFIDENCE = 0.3  # a slot with a joint above this confidence is a person in view


@dataclass(frozen=True)
class PatientChoice:
    """The clinician's choice of the patient: a track id, who chose it, and how (words)."""

    track_id: int
    chosen_by: str = ""
    how: str = ""

    def __post_init__(self) -> None:
        if isinstance(self.track_id, bool) or not isinstance(self.track_id, int) or self.track_id < 0:
            raise ValueError(f"track_id: must be an integer >= 0, got {self.track_id!r}")


def most_people_in_view(keypoints: MultiViewKeypoints, *, threshold: float = IN_VIEW_CONFIDENCE) -> int:
    """Most people seen (a joint above ``threshold``) by one camera in one frame."""
    return int(keypoints.confident(threshold).any(-1).sum(-1).max(initial=0))


def select_patient(recording: MultiViewKeypoints, rig: Rig, choice: PatientChoice | None, selector=None
                   ) -> PatientSelection:
    """Associate everyone in ``recording`` and choose the patient: ``selector`` (a track selector, e.g.
    ``--person`` / ``--patient-near``) wins, then ``choice`` (the clinician's), else automatic.

    ValueError when the chosen track does not exist (e.g. a choice made before the recording changed).
    """
    from gaitcap.reconstruction.association import associate_and_select

    if selector is None and choice is not None:
        selector = ManualTrack(choice.track_id)
    try:
        return associate_and_select(recording, rig.subset(recording.camera_names), selector)
    except ValueError as exc:
        if choice is None:
            raise
        raise ValueError(f"the patient chosen by {choice.chosen_by or 'the clinician'} (track "
                         f"{choice.track_id}): {exc}") from None


def patient_detections_of(recording: MultiViewKeypoints, rig: Rig, files: TrialFiles, *, selector=None
                          ) -> tuple[MultiViewKeypoints, PatientSelection | None]:
    """The patient's detections: the only person of a single-person recording (nothing else is done), or
    the chosen track of several people in view (then ``people.json`` and ``tracks.npz`` are written)."""
    if most_people_in_view(recording) <= 1:
        return recording.patient(), None
    choice = read_choice(files)
    selection = select_patient(recording, rig, choice, selector)
    sizes = {cam.name: [int(v) for v in cam.size_px] for cam in rig.cameras if cam.name in recording.camera_names}
    busiest = busiest_frame(selection.tracks)
    how = "requested" if selector is not None else "clinician" if choice is not None else "automatic"
    write_people(files, selection, chosen_by=how, first_frame_id=int(recording.frame_ids[0]), image_sizes_px=sizes,
                 busiest=busiest, boxes=boxes_in_frame(recording, selection.tracks, busiest))
    log.info("%s: %d people tracked; patient is track %d (%s)", files.root.name, selection.tracks.num_tracks,
             selection.track_id, how)
    return selection.detections, selection


def patient_selection(recording: MultiViewKeypoints, rig: Rig, choice: PatientChoice | None = None, *,
                      selector=None
                      ) -> tuple[MultiViewKeypoints, PatientSelection | None]:
    """The patient's detections as :func:`patient_detections_of` finds them, and the selection (None with
    one person in view); writes nothing."""
    if most_people_in_view(recording) <= 1:
        return recording.patient(), None
    selection = select_patient(recording, rig, choice, selector)
    return selection.detections, selection


def patient_of(recording: MultiViewKeypoints, rig: Rig, choice: PatientChoice | None = None) -> MultiViewKeypoints:
    """The patient's detections as :func:`patient_detections_of` finds them, writing nothing."""
    return patient_selection(recording, rig, choice)[0]


# ------------------------------------------------------------------ files
def busiest_frame(tracks: Tracks) -> int:
    """A frame with the most people in view (and, among those, the most camera views)."""
    return int(np.argmax(tracks.seen().sum(0) * 1000 + tracks.views.sum(0)))


def boxes_in_frame(multi: MultiViewKeypoints, tracks: Tracks, frame: int) -> dict[str, list[dict]]:
    """Per camera, each tracked person's keypoint box in ``frame``: ``[{"track_id", "box_px": [x0, y0,
    x1, y1]}]`` (for marking the people on that frame's images)."""
    ok = multi.confident(IN_VIEW_CONFIDENCE)[:, frame]  # (C, P, J)
    out: dict[str, list[dict]] = {}
    for c, cam in enumerate(multi.camera_names):
        for p, track in enumerate(tracks.detection_track[c, frame]):
            if track < 0 or not ok[c, p].any():
                continue
            xy = multi.keypoints[c, frame, p, ok[c, p], :2]
            box = [*np.min(xy, 0), *np.max(xy, 0)]
            out.setdefault(cam, []).append({"track_id": int(track), "box_px": [round(float(v), 1) for v in box]})
    return out


def people_summary(selection: PatientSelection, *, chosen_by: str, first_frame_id: int = 0,
                   image_sizes_px: dict | None = None, busiest: int | None = None, boxes: dict | None = None) -> dict:
    """The JSON of ``people.json`` (see the module docstring)."""
    tracks = selection.tracks
    people = [{"track_id": s.track_id, "first_s": round(s.first_s, 3), "last_s": round(s.last_s, 3),
               "seen_s": round(s.last_s - s.first_s, 3), "frames": s.frames, "mean_views": round(s.mean_views, 2),
               "path_mm": round(s.path_mm, 1), "mean_position_mm": [round(v, 1) for v in s.mean_position_mm]}
              for s in tracks.summaries()]
    busiest = busiest_frame(tracks) if busiest is None else busiest
    return {"cameras": list(tracks.camera_names), "frames": int(tracks.times_s.size), "first_frame_id": first_frame_id,
            "busiest_frame": busiest, "image_sizes_px": image_sizes_px or {}, "boxes_px": boxes or {},
            "patient_track_id": int(selection.track_id), "chosen_by": chosen_by, "people": people}


def write_people(files: TrialFiles, selection: PatientSelection, **summary) -> None:
    """``people.json`` and ``tracks.npz``; ``summary``: the keyword arguments of :func:`people_summary`."""
    save_tracks(selection.tracks, files.tracks_npz)
    body = json.dumps(people_summary(selection, **summary), indent=1)
    atomic_write_bytes(files.people_json, body.encode())


def read_people(files: TrialFiles) -> dict | None:
    """``people.json`` or None when the trial had one person in view (or is not processed yet)."""
    path = files.people_json
    return json.loads(path.read_text()) if path.is_file() else None


def read_choice(files: TrialFiles) -> PatientChoice | None:
    path = files.patient_choice_json
    if not path.is_file():
        return None
    data = json.loads(path.read_text())
    return PatientChoice(track_id=int(data["track_id"]), chosen_by=str(data.get("chosen_by", "")),
                         how=str(data.get("how", "")))


def write_choice(files: TrialFiles, choice: PatientChoice) -> None:
    body = json.dumps({"track_id": choice.track_id, "chosen_by": choice.chosen_by, "how": choice.how})
    atomic_write_bytes(files.patient_choice_json, body.encode())


_TRACK_ARRAYS = ("detection_track", "root_mm", "points_mm", "views", "joint_indices", "camera_names", "times_s")


def save_tracks(tracks: Tracks, path: Path) -> None:
    atomic_savez(path, **{k: np.asarray(getattr(tracks, k)) for k in _TRACK_ARRAYS})


def load_tracks(path: Path) -> Tracks:
    with np.load(path, allow_pickle=False) as data:
        return Tracks(detection_track=data["detection_track"], root_mm=data["root_mm"], points_mm=data["points_mm"],
                      views=data["views"], joint_indices=tuple(int(i) for i in data["joint_indices"]),
                      camera_names=tuple(str(n) for n in data["camera_names"]), times_s=data["times_s"])


def track_at_click(files: TrialFiles, *, camera: str, frame: int, x_px: float, y_px: float) -> int:
    """The track of the person under a click on ``camera``'s image of ``frame`` (0 = the first frame of
    the recording). LookupError when the trial has no tracks; ValueError naming the camera, frame or
    pixel when nobody is there."""
    from gaitcap.acquisition.recording.reader import read_keypoints
    from gaitcap.reconstruction.association import select_track_at_pixel

    if not files.tracks_npz.is_file():
        raise LookupError("this trial has no tracked people (one person in view, or not processed yet)")
    tracks = load_tracks(files.tracks_npz)
    if camera not in tracks.camera_names:
        raise KeyError(f"camera {camera!r} is not in this trial (cameras: {list(tracks.camera_names)})")
    multi = read_keypoints(files.recording, list(tracks.camera_names))
    return select_track_at_pixel(multi, tracks, camera=camera, frame=frame, x_px=x_px, y_px=y_px)


def recorded_still(files: TrialFiles, *, camera: str, frame_id: int) -> bytes | None:
    """The JPEG ``camera`` recorded for ``frame_id`` (the recorder's frame id), None when not recorded."""
    from gaitcap.acquisition.recording.reader import iter_frames

    for recorded in iter_frames(files.recording, camera):
        if recorded.frame_id == frame_id:
            return recorded.jpeg
    return None
