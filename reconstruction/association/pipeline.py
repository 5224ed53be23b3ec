"""Association end to end: unordered multi-person keypoints -> tracks -> the patient's detections."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from gaitcap.reconstruction.association.completion import complete_tracks
from gaitcap.reconstruction.association.crossview import AssociationConfig, associate_frames
from gaitcap.reconstruction.association.orientation import face_forward
from gaitcap.reconstruction.association.selection import TrackSelector, WalkwayTrack, patient_detections
from gaitcap.reconstruction.association.tracking import TrackingConfig, Tracks, link_tracks
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints


@dataclass(frozen=True)
class PipelineConfig:
    """Settings of :func:`associate` (per-frame association, temporal linking, then track completion).

    Attributes:
        completion_gap_s: detections left unassigned by the per-frame association are given to the
            track they continue (:mod:`.completion`) up to this long (s) before, after or between the
            track's sightings; 0 turns completion off.
    """

    association: AssociationConfig = field(default_factory=AssociationConfig)
    tracking: TrackingConfig = field(default_factory=TrackingConfig)
    completion_gap_s: float = 0.5

    def __post_init__(self) -> None:
        if not self.completion_gap_s >= 0:
            raise ValueError(f"PipelineConfig.completion_gap_s must be >= 0, got {self.completion_gap_s}")


@dataclass(frozen=True, eq=False)
class PatientSelection:
    """Result of :func:`associate_and_select`.

    Attributes:
        tracks: every tracked person.
        track_id: the chosen track.
        detections: the chosen track's keypoints (C, T, J, 3), the input of reconstruction.
    """

    tracks: Tracks
    track_id: int
    detections: MultiViewKeypoints


def associate(multi: MultiViewKeypoints, rig: Rig, config: PipelineConfig = PipelineConfig()) -> Tracks:
    """Per-frame cross-view association, temporal linking and track completion of every person in view;
    each track's frames turned the right way round (:func:`.orientation.face_forward`) when the up axis
    is known (``config.tracking.up_axis``)."""
    people = associate_frames(multi, rig, config.association)
    tracks = link_tracks(people, multi.times_s, multi.camera_names, config.tracking)
    if config.completion_gap_s > 0:
        tracks = complete_tracks(multi, rig, tracks, config.association, max_gap_s=config.completion_gap_s)
    if config.tracking.up_axis is None:
        return tracks
    return face_forward(tracks, multi.skeleton, up_axis=config.tracking.up_axis)


def default_selector(rig: Rig, *, up_axis: int = 2, aim_height_mm: float = 900.0) -> WalkwayTrack:
    """Automatic choice of the patient: the person who walks the walkway.

    The walkway is where the cameras look: the line through the points where their optical axes reach
    ``aim_height_mm`` above the floor (when those points spread along a line). Otherwise (e.g. every
    camera aimed at one spot) it runs through the centre of the rig along the people's main motion.
    """
    line = walkway_from_rig(rig, up_axis=up_axis, aim_height_mm=aim_height_mm)
    if line is not None:
        return WalkwayTrack(start_mm=line[0], end_mm=line[1], up_axis=up_axis)
    centre = np.mean([cam.center_mm for cam in rig.cameras], axis=0)
    return WalkwayTrack(through_mm=tuple(float(v) for v in centre), up_axis=up_axis)


def walkway_from_rig(
    rig: Rig, *, up_axis: int = 2, aim_height_mm: float = 900.0, min_length_mm: float = 2000.0
) -> tuple[tuple[float, float, float], tuple[float, float, float]] | None:
    """The line the cameras aim along, as two points (mm), or None when their aim points do not spread
    along a line at least ``min_length_mm`` long (twice the standard deviation along it)."""
    aims = []
    for cam in rig.cameras:
        axis = cam.rotation[2]  # optical axis in world coordinates
        if axis[up_axis] >= -1e-3:
            continue  # level or upward: never reaches the aim height in front of the camera
        s = (aim_height_mm - cam.center_mm[up_axis]) / axis[up_axis]
        if 0 < s < 30_000:
            aims.append(cam.center_mm + s * axis)
    if len(aims) < 3:
        return None
    aims = np.array(aims)
    floor = np.delete(aims, up_axis, axis=1)
    centre = floor.mean(0)
    _, sv, vt = np.linalg.svd(floor - centre, full_matrices=False)
    spread = sv / np.sqrt(len(floor))  # standard deviations along the principal axes
    if 2 * spread[0] < min_length_mm or spread[0] < 3 * spread[1]:
        return None
    ends = []
    for sign in (-1, 1):
        xy = centre + sign * 2 * spread[0] * vt[0]
        ends.append(tuple(float(v) for v in np.insert(xy, up_axis, 0.0)))
    return ends[0], ends[1]


def associate_and_select(
    multi: MultiViewKeypoints,
    rig: Rig,
    selector: TrackSelector | None = None,
    config: PipelineConfig = PipelineConfig(),
) -> PatientSelection:
    """Associate everyone, choose the patient (``selector``, default :func:`default_selector`), and
    return the patient's detections for reconstruction."""
    tracks = associate(multi, rig, config)
    chosen = (selector or default_selector(rig)).choose(tracks)
    return PatientSelection(tracks=tracks, track_id=chosen,
                            detections=patient_detections(multi, tracks, chosen))

