"""Keypoint layouts recognised from the keypoints: the same synthetic walk written in every layout."""

import logging

import numpy as np
import pytest
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.layout_guess import (
    AmbiguousLayout,
    LayoutScore,
    candidate_layouts,
    choose_layout,
    sample_points,
    score_layout,
)
from gaitcap.reconstruction.skeletons import SKELETONS, get_skeleton
from gaitcap.simulator.layouts import points_in_layout


@pytest.fixture(scope="module")
def walk():
    from gaitcap.simulator import make_trial

    trial = make_trial(preset="paper", seconds=4.0, cameras=4, seed=3)
    return trial.rig, trial.points_mm, trial.times_s


def _detections(rig, points, times, layout: str, *, seed: int = 0) -> MultiViewKeypoints:
    rng = np.random.default_rng(seed)
    px = rig.project(points) + rng.normal(0, 1.5, (len(rig.cameras), *points.shape[:2], 2))
    kp = np.concatenate([px, np.full(px.shape[:-1] + (1,), 0.9)], -1)
    return MultiViewKeypoints.of_one_person(kp, rig.names, times, candidate_layouts(points.shape[1])[0])


def _recognise(rig, det: MultiViewKeypoints, explicit=None):
    pts = sample_points(det, rig, max_frames=40)
    return choose_layout([score_layout(pts, s) for s in candidate_layouts(det.shape[3])], explicit=explicit)


@pytest.mark.parametrize("layout", sorted(SKELETONS))
def test_every_layout_is_recognised(walk, layout):
    rig, points, times = walk
    det = _detections(rig, points_in_layout(points, layout), times, layout)
    choice = _recognise(rig, det)
    assert choice.skeleton == layout, choice.evidence()
    assert choice.score_of(layout).limb_sd_mm < 15, choice.evidence()
    assert choice.score_of(layout).misplaced < 0.05, choice.evidence()
    assert not choice.warnings
    if len(choice.scores) > 1:  # BODY_25 vs BODY_25B: the wrong one is far off
        assert choice.how == "recognised" and choice.margin_mm > 50, choice.evidence()


def test_body25b_read_as_body25_is_warned_about(walk, caplog):
    rig, points, times = walk
    det = _detections(rig, points_in_layout(points, "body25b"), times, "body25b")
    choice = _recognise(rig, det, explicit="body25")
    assert choice.skeleton == "body25" and choice.how == "explicit"  # an explicit choice always wins
    assert len(choice.warnings) == 1
    assert "--skeleton body25 looks inconsistent" in choice.warnings[0] and "body25b" in choice.warnings[0]


def test_mirrored_layout_is_misplaced(walk):
    """Left and right swapped: limb lengths agree, the anatomical checks do not."""
    rig, points, times = walk
    skel = get_skeleton("halpe26")
    flipped = points[:, list(skel.flip_permutation)]
    right, mirrored = score_layout(points, skel), score_layout(flipped, skel)
    assert right.misplaced < 0.05 and mirrored.misplaced > 0.2  # nose and toes behind in every frame


def test_close_layouts_are_refused_naming_both():
    a = LayoutScore("body25", 10.0, 2.0, 0.0, 40)
    b = LayoutScore("body25b", 11.0, 2.5, 0.0, 40)
    with pytest.raises(AmbiguousLayout, match=r"body25 and body25b.*--skeleton body25 or --skeleton body25b"):
        choose_layout([a, b])
    assert choose_layout([a, b], explicit="body25b").skeleton == "body25b"


def test_unknown_joint_count_is_an_error():
    with pytest.raises(ValueError, match="no known layout has 7 keypoints"):
        candidate_layouts(7)
    logging.getLogger(__name__).debug("ok")
