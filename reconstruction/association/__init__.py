"""Several people in view: cross-view association, tracking, choosing the patient, person boxes.

Input: :class:`~gaitcap.reconstruction.keypoints.MultiViewKeypoints` (C, T, P, J, 3) with people in arbitrary order per camera and
frame. :func:`associate` -> :class:`Tracks`; a selector (:class:`WalkwayTrack`,
:class:`NearestStartTrack`, :class:`ManualTrack`) picks the patient; :func:`patient_detections` gives
the one person's :class:`~gaitcap.reconstruction.keypoints.MultiViewKeypoints` (P == 1) that reconstruction uses; :func:`person_boxes`
reprojects a 3D reconstruction into per-camera boxes for top-down detectors.
"""

from gaitcap.reconstruction.association.boxes import BoxConfig, person_boxes, track_boxes
from gaitcap.reconstruction.association.crossview import AssociationConfig, FramePeople, associate_frames
from gaitcap.reconstruction.association.evaluation import AssociationScore, score_association
from gaitcap.reconstruction.association.pipeline import (
    PatientSelection,
    PipelineConfig,
    associate,
    associate_and_select,
    default_selector,
    walkway_from_rig,
)
from gaitcap.reconstruction.association.selection import (
    ManualTrack,
    NearestStartTrack,
    TrackSelector,
    WalkwayTrack,
    patient_detections,
    select_track_at_pixel,
)
from gaitcap.reconstruction.association.tracking import TrackingConfig, Tracks, TrackSummary, link_tracks

__all__ = [
    "AssociationConfig", "AssociationScore", "BoxConfig", "FramePeople", "ManualTrack",
    "NearestStartTrack", "PatientSelection", "PipelineConfig", "TrackSelector",
    "TrackSummary", "TrackingConfig", "Tracks", "WalkwayTrack", "associate", "associate_and_select",
    "associate_frames",
    "default_selector", "link_tracks", "patient_detections", "person_boxes", "score_association",
    "select_track_at_pixel", "track_boxes", "walkway_from_rig",
]
