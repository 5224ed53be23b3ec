"""The simulated detector returns the synthetic world's noisy keypoints per camera and frame."""

import numpy as np
import pytest
from gaitcap.acquisition.detectors.base import DETECTOR_CONFIGS, Detector
from gaitcap.acquisition.detectors.simulated import SimulatedConfig
from gaitcap.simulator import make_trial


@pytest.fixture(scope="module")
def trials():
    return make_trial(seconds=4, cameras=3, people=1, seed=1), make_trial(seconds=4, cameras=3, people=3, seed=2)


def test_single_person_matches_the_trial(trials):
    one, _ = trials
    det = SimulatedConfig(trial=one).build()
    assert isinstance(det, Detector) and DETECTOR_CONFIGS["simulated"] is SimulatedConfig
    assert det.skeleton.name == one.detections.skeleton.name
    cam = one.rig.names[1]
    c = one.detections.camera_names.index(cam)
    for f in (0, 57, one.num_frames - 1):
        kp = det.detect(None, camera=cam, frame_id=f, timestamp_ns=0)
        ref = one.detections.one_person[c, f]
        if kp.shape[0] == 0:  # the patient is out of this view
            assert not (np.nan_to_num(ref[:, 2]) > 0).any()
            continue
        assert kp.shape == (1, one.skeleton.num_joints, 3)
        np.testing.assert_array_equal(kp[0], ref)
    # Deterministic, and noisy: not the exact projection of the ground truth.
    np.testing.assert_array_equal(det.detect(None, camera=cam, frame_id=5, timestamp_ns=1),
                                  det.detect(None, camera=cam, frame_id=5, timestamp_ns=2))
    truth_px = one.rig[cam].project(one.points_mm[57])
    err = np.linalg.norm(det.detect(None, camera=cam, frame_id=57, timestamp_ns=0)[0, :, :2] - truth_px, axis=-1)
    assert 0 < np.nanmedian(err) < 50


def test_several_people_and_empty_slots(trials):
    _, three = trials
    det = SimulatedConfig(trial=three).build()
    multi = three.multi.observed.keypoints
    counts = []
    for c, cam in enumerate(three.rig.names):
        for f in range(0, three.num_frames, 7):
            kp = det.detect(None, camera=cam, frame_id=f, timestamp_ns=0)
            seen = (np.nan_to_num(multi[c, f, :, :, 2]) > 0).any(-1)
            assert kp.shape == (int(seen.sum()), three.skeleton.num_joints, 3)
            np.testing.assert_array_equal(kp, multi[c, f][seen])
            counts.append(kp.shape[0])
    assert max(counts) >= 2


def test_bad_camera_or_frame_is_named(trials):
    one, _ = trials
    det = SimulatedConfig(trial=one).build()
    with pytest.raises(ValueError, match="unknown camera 'nope'"):
        det.detect(None, camera="nope", frame_id=0, timestamp_ns=0)
    with pytest.raises(ValueError, match="frame id -1 is negative"):
        det.detect(None, camera=one.rig.names[0], frame_id=-1, timestamp_ns=0)


def test_frame_ids_past_the_walk_are_the_walk_played_again(trials):
    one, _ = trials
    det = SimulatedConfig(trial=one).build()
    cam, n = one.rig.names[1], one.num_frames
    for f in (0, 7, n - 1):
        again = det.detect(None, camera=cam, frame_id=f + 2 * n, timestamp_ns=0)
        np.testing.assert_array_equal(again, det.detect(None, camera=cam, frame_id=f, timestamp_ns=0))
    assert not np.array_equal(det.detect(None, camera=cam, frame_id=n, timestamp_ns=0),
                              det.detect(None, camera=cam, frame_id=n - 1, timestamp_ns=0))
