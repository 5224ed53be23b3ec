"""Track completion: detections the per-frame association left out go back to the track they continue."""

import dataclasses

import numpy as np
import pytest
from gaitcap.reconstruction.association import AssociationConfig, PipelineConfig, TrackingConfig, link_tracks
from gaitcap.reconstruction.association.completion import complete_tracks, predicted_points
from gaitcap.reconstruction.association.crossview import associate_frames

from .conftest import make_scene


def _linked(scene):
    people = associate_frames(scene.multi, scene.rig, AssociationConfig())
    return link_tracks(people, scene.multi.times_s, scene.multi.camera_names, TrackingConfig())


def _without(tracks, track_id, frames):
    """``tracks`` with ``track_id`` not seen in ``frames`` (its detections unassigned there)."""
    det = tracks.detection_track.copy()
    cut = det[:, frames] == track_id
    det[:, frames] = np.where(cut, -1, det[:, frames])
    points, root, views = tracks.points_mm.copy(), tracks.root_mm.copy(), tracks.views.copy()
    points[track_id, frames], root[track_id, frames], views[track_id, frames] = np.nan, np.nan, 0
    return dataclasses.replace(tracks, detection_track=det, points_mm=points, root_mm=root, views=views)


def test_lost_frames_at_the_start_and_in_the_middle_come_back_to_their_track():
    scene = make_scene(frames=60, people=2, seed=3)
    full = _linked(scene)
    assert full.num_tracks == 2 and (full.views > 0).all()
    lost = [0, 1, 2, *range(20, 26)]
    cut = _without(full, 0, lost)
    done = complete_tracks(scene.multi, scene.rig, cut, AssociationConfig(), max_gap_s=0.5)
    assert np.array_equal(done.detection_track, full.detection_track)  # each detection back, none misplaced
    assert (done.views == full.views).all()
    err = np.linalg.norm(done.points_mm[0, lost] - full.points_mm[0, lost], axis=-1)
    assert np.nanmax(err) < 1.0  # triangulated again from the same detections (mm)
    untouched = np.setdiff1d(np.arange(60), lost)
    assert np.array_equal(done.points_mm[:, untouched], full.points_mm[:, untouched], equal_nan=True)


def test_nothing_is_given_beyond_the_gap_or_to_a_prediction_that_does_not_fit():
    scene = make_scene(frames=60, people=2, seed=3)
    full = _linked(scene)
    cut = _without(full, 0, list(range(0, 30)))  # first seen at 1.0 s
    done = complete_tracks(scene.multi, scene.rig, cut, AssociationConfig(), max_gap_s=0.2)
    back = (done.views[0] > 0) & (cut.views[0] == 0)
    assert back[24:30].all() and not back[:23].any()  # held for at most 0.2 s (6 frames at 30 fps)
    # the walker moves 1.2 m/s: a prediction held 0.5 s reaches 600 mm behind, out of the gate
    far = complete_tracks(scene.multi, scene.rig, cut, AssociationConfig(), max_gap_s=5.0)
    assert (far.views[0, :10] == 0).all()
    assert np.array_equal(far.detection_track[far.detection_track == 1], full.detection_track[full.detection_track == 1])


def test_predictions_interpolate_between_sightings_and_hold_at_the_ends():
    times = np.arange(6) * 0.1
    pts = np.full((1, 6, 1, 3), np.nan)
    pts[0, 1, 0], pts[0, 4, 0] = [0.0, 0.0, 900.0], [300.0, 0.0, 900.0]
    pred = predicted_points(pts, times, max_gap_s=0.15)
    assert np.allclose(pred[0, :, 0, 0], [0, 0, 100, 200, 300, 300])
    assert np.isnan(predicted_points(pts, times, max_gap_s=0.05)[0, [0, 2, 3, 5], 0]).all()


def test_completion_gap_is_checked_and_zero_turns_it_off():
    with pytest.raises(ValueError, match="completion_gap_s"):
        PipelineConfig(completion_gap_s=-1.0)
    assert PipelineConfig(completion_gap_s=0.0).completion_gap_s == 0.0
