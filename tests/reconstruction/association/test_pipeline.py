"""End to end on the synthetic world: several people in view -> the patient's reconstruction."""

import numpy as np
import pytest
from gaitcap.reconstruction.association import (
    BoxConfig,
    ManualTrack,
    associate_and_select,
    person_boxes,
    score_association,
    select_track_at_pixel,
)
from gaitcap.reconstruction.gait.analysis import analyze_gait
from gaitcap.reconstruction.triangulation import robust_triangulate
from gaitcap.simulator import make_trial

SECONDS = 12.0


def _mpjpe(points_mm, truth_mm) -> float:
    return float(np.nanmean(np.linalg.norm(points_mm - truth_mm, axis=-1)))


@pytest.fixture(scope="module")
def three():
    trial = make_trial(preset="paper", seconds=SECONDS, cameras=10, people=3, seed=0)
    return trial, associate_and_select(trial.multi.observed, trial.rig)


def test_everyone_is_tracked_without_identity_switches(three):
    trial, chosen = three
    score = score_association(chosen.tracks.detection_track, trial.multi.identity)
    assert score.identity_switches == 0
    assert len(set(score.main_track)) == 3 and -1 not in score.main_track
    assert score.wrong_fraction < 0.002 and score.missed_fraction < 0.01
    assert chosen.tracks.num_tracks == 3


def test_the_patient_is_chosen_and_reconstructed_as_well_as_alone_with_no_step_lost(three):
    trial, chosen = three
    score = score_association(chosen.tracks.detection_track, trial.multi.identity)
    assert chosen.track_id == score.main_track[0]
    selected = robust_triangulate(chosen.detections, trial.rig).points_mm
    alone = robust_triangulate(trial.detections, trial.rig).points_mm
    assert _mpjpe(selected, trial.points_mm) <= 1.10 * _mpjpe(alone, trial.points_mm)
    names = trial.skeleton.joint_names
    steps_selected = analyze_gait(selected, trial.times_s, names).steps
    steps_alone = analyze_gait(alone, trial.times_s, names).steps
    assert len(steps_alone) > 0
    for step in steps_alone:  # no step lost: each one is found again, same foot, same time
        assert any(s.foot == step.foot and abs(s.heel_strike_s - step.heel_strike_s) < 0.05
                   for s in steps_selected), f"step lost: {step.foot} heel strike {step.heel_strike_s:.2f} s"


def test_a_click_on_a_preview_selects_the_person_under_it(three):
    trial, chosen = three
    multi = trial.multi.observed
    c, frame = 4, 100
    for person in range(3):
        slots = np.flatnonzero(trial.multi.identity[c, frame] == person)
        if slots.size == 0:
            continue
        kp = trial.multi.observed.keypoints[c, frame, slots[0]]
        j = int(np.argmax(kp[:, 2]))
        track = select_track_at_pixel(multi, chosen.tracks, camera=trial.rig.names[c], frame=frame,
                                      x_px=kp[j, 0], y_px=kp[j, 1])
        assert track == score_association(chosen.tracks.detection_track, trial.multi.identity).main_track[person]


def test_boxes_from_the_chosen_reconstruction_hold_the_patient(three):
    trial, chosen = three
    points = robust_triangulate(chosen.detections, trial.rig).points_mm
    boxes = person_boxes(trial.rig, points, BoxConfig(padding_fraction=0.15))
    truth_px = trial.rig.project(trial.points_mm)  # (C, T, J, 2)
    inside_img = np.stack([cam.in_image(truth_px[i]) for i, cam in enumerate(trial.rig.cameras)])
    lo, hi = boxes[:, :, None, :2], boxes[:, :, None, 2:]
    held = ((truth_px >= lo) & (truth_px <= hi)).all(-1)
    has_box = np.isfinite(boxes).all(-1)[..., None] & inside_img
    assert has_box.mean() > 0.5
    assert held[has_box].mean() > 0.995


def test_manual_choice_of_the_therapist_gives_the_therapists_detections():
    trial = make_trial(preset="paper", seconds=6.0, cameras=10, people=2, seed=1)
    multi = trial.multi.observed
    auto = associate_and_select(multi, trial.rig)
    score = score_association(auto.tracks.detection_track, trial.multi.identity)
    assert auto.track_id == score.main_track[0]
    therapist = associate_and_select(multi, trial.rig, ManualTrack(score.main_track[1]))
    mine = therapist.detections.one_person[..., 0]
    raw = trial.multi.person(1)
    truth = raw[..., 0]
    unmirrored = raw[:, :, list(trial.skeleton.flip_permutation), 0]  # detections the association turned
    agree = np.isfinite(mine) & np.isfinite(truth)
    same = (mine == truth) | (mine == unmirrored)
    assert same[agree].all() and agree.sum() > 0.95 * np.isfinite(truth).sum()
    turned = (np.isfinite(mine) & (mine != truth)).any(-1)  # (C, T) detections swapped back
    assert turned.sum() < 0.1 * np.isfinite(mine).any(-1).sum()  # the simulated swaps are rare


def test_associate_and_select_finds_the_patient(scene3):
    from gaitcap.reconstruction.association import associate_and_select

    got = associate_and_select(scene3.multi, scene3.rig)
    patient = int(np.bincount(got.tracks.detection_track[scene3.identity == 0]).argmax())
    assert got.track_id == patient and got.detections.shape == (8, 60, 1, 26)


def test_close_companion_and_a_person_crossing_between_cameras(crossing_scene):
    from gaitcap.reconstruction.association import associate

    tracks = associate(crossing_scene.multi, crossing_scene.rig)
    score = score_association(tracks.detection_track, crossing_scene.identity)
    assert tracks.num_tracks == 3 and score.identity_switches == 0
    assert score.wrong_fraction < 0.005 and score.missed_fraction < 0.005


def test_six_people_in_view(six_scene):
    from gaitcap.reconstruction.association import associate

    tracks = associate(six_scene.multi, six_scene.rig)
    score = score_association(tracks.detection_track, six_scene.identity)
    assert tracks.num_tracks == 6 and len(set(score.main_track)) == 6
    assert score.identity_switches == 0 and score.wrong == 0 and score.missed == 0
