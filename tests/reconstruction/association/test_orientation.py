"""Left and right from the body: mirrored track frames are turned back, detections swapped back."""

import dataclasses

import numpy as np
from gaitcap.reconstruction.association import (
    AssociationConfig,
    ManualTrack,
    TrackingConfig,
    associate_and_select,
    link_tracks,
    patient_detections,
)
from gaitcap.reconstruction.association.crossview import associate_frames
from gaitcap.reconstruction.association.orientation import face_forward, mirrored_frames
from gaitcap.reconstruction.skeletons import get_skeleton

from .conftest import make_scene, person_points

SKELETON = get_skeleton("halpe26")
NAMES = tuple(SKELETON.joint_names)


def _walker(frames=40):
    t = np.arange(frames) / 30
    xy = np.stack([-1500 + 1200 * t, np.zeros(frames)], -1)
    return person_points(xy, np.full(frames, 0.3), 2 * np.pi * t)  # (T, J, 3), heading 17 deg


def test_a_run_of_mirrored_frames_is_found_and_nothing_else():
    body = _walker()
    assert not mirrored_frames(body, NAMES).any()
    mirrored = body.copy()
    mirrored[10:20] = body[10:20][:, list(SKELETON.flip_permutation)]
    found = mirrored_frames(mirrored, NAMES)
    assert found[10:20].all() and found.sum() == 10


def test_one_badly_placed_nose_turns_nothing():
    body = _walker()
    nose = NAMES.index("nose")
    body[12, nose, 0] -= 200.0  # 120 mm behind the shoulders in one frame, still a plausible head
    assert not mirrored_frames(body, NAMES).any()
    body[25, nose] = [5000.0, 0.0, 0.0]  # no head at all: ignored
    assert not mirrored_frames(body, NAMES).any()


def test_without_the_joints_nothing_is_decided():
    body = _walker()
    names = tuple("x" if n == "nose" else n for n in NAMES)
    assert not mirrored_frames(body[:, list(SKELETON.flip_permutation)], names).any()


def test_face_forward_turns_the_track_and_its_detections_and_the_patient_is_swapped_back():
    scene = make_scene(frames=30, people=2, seed=2)
    people = associate_frames(scene.multi, scene.rig, AssociationConfig())
    tracks = link_tracks(people, scene.multi.times_s, scene.multi.camera_names, TrackingConfig())
    assert not tracks.mirrored().any()  # every view straight
    assert face_forward(tracks, SKELETON) is tracks
    names = tuple(NAMES[j] for j in tracks.joint_indices)
    swap = [names.index(NAMES[SKELETON.flip_permutation[j]]) for j in tracks.joint_indices]
    points = tracks.points_mm.copy()
    points[0, 5:15] = points[0, 5:15][:, swap]  # as if most views had shown the patient mirrored
    turned = face_forward(dataclasses.replace(tracks, points_mm=points), SKELETON)
    assert np.allclose(turned.points_mm, tracks.points_mm, equal_nan=True)
    own = tracks.detection_track == 0
    assert (turned.mirrored() == (own & (np.arange(30)[None, :, None] >= 5) & (np.arange(30)[None, :, None] < 15))).all()
    straight = patient_detections(scene.multi, tracks, 0).one_person
    swapped = patient_detections(scene.multi, turned, 0).one_person
    assert np.array_equal(swapped[:, 5:15], straight[:, 5:15][:, :, list(SKELETON.flip_permutation)], equal_nan=True)
    assert np.array_equal(swapped[:, 15:], straight[:, 15:], equal_nan=True)


def test_a_view_the_detector_mirrored_is_swapped_back_and_no_other_is_turned():
    scene = make_scene(frames=30, people=2, seed=4)
    kp = scene.multi.keypoints.copy()
    patient = scene.identity == 0  # (C, T, P)
    turn = np.zeros_like(patient)
    turn[2, 10:20] = patient[2, 10:20]  # camera 2 shows the patient mirrored for 10 frames
    kp[turn] = kp[turn][:, list(SKELETON.flip_permutation)]
    multi = dataclasses.replace(scene.multi, keypoints=kp)
    tracks = associate_and_select(multi, scene.rig).tracks
    patient_track = int(np.bincount(tracks.detection_track[patient & (tracks.detection_track >= 0)]).argmax())
    chosen = associate_and_select(multi, scene.rig, ManualTrack(patient_track))
    truth = np.take_along_axis(scene.multi.keypoints, np.argmax(patient, -1)[..., None, None, None], 2)[:, :, 0]
    got = chosen.detections.one_person
    seen = np.isfinite(got[..., 0]).all(-1)  # (C, T)
    assert seen[2, 10:20].all() and seen.mean() > 0.95
    assert np.array_equal(got[seen], truth[seen])  # the mirrored view swapped back, every other one as it was
