"""Association end to end: unordered multi-person keypoints -> tracks -> the patient's detections."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from reconstruction.association.crossview import AssociationConfig, associate_frames
from reconstruction.association.multi import MultiPersonDetections
from reconstruction.association.selection import TrackSelector, WalkwayTrack, patient_detections
from reconstruction.association.tracking import TrackingConfig, Tracks, link_tracks
from reconstruction.camera import Rig
from reconstruction.detections import Detections


@dataclass(frozen=True)
class PipelineConfig:
    """Settings of :func:`associate` (per-frame association, then temporal linking)."""

    association: AssociationConfig = field(default_factory=AssociationConfig)
    tracking: TrackingConfig = field(default_factory=TrackingConfig)


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
    detections: Detections


def associate(multi: MultiPersonDetections, rig: Rig, config: PipelineConfig = PipelineConfig()) -> Tracks:
    """Per-frame cross-view association and temporal linking of every person in view."""
    people = associate_frames(multi, rig, config.association)
    return link_tracks(people, multi.times_s, multi.camera_names, config.tracking)


def default_selector(rig: Rig, *, up_axis: int = 2) -> WalkwayTrack:
    """Automatic choice: the walkway runs through the centre of the rig along the main motion."""
    centre = np.mean([cam.center_mm for cam in rig.cameras], axis=0)
    return WalkwayTrack(through_mm=tuple(float(v) for v in centre), up_axis=up_axis)


def associate_and_select(
    multi: MultiPersonDetections,
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


def associate_keypoints(
    keypoints: np.ndarray,
    *,
    rig: Rig,
    camera_names,
    times_s: np.ndarray,
    skeleton: str = "halpe26",
    selector: TrackSelector | None = None,
    config: PipelineConfig = PipelineConfig(),
) -> PatientSelection:
    """:func:`associate_and_select` on raw arrays: ``keypoints`` (C, T, P, J, 3) x px, y px, confidence
    in any per-frame order, ``camera_names`` (C,), ``times_s`` (T,). ValueError on bad input."""
    multi = MultiPersonDetections(keypoints=keypoints, camera_names=tuple(camera_names), times_s=times_s,
                                  skeleton=skeleton)
    return associate_and_select(multi, rig, selector, config)
