"""The simulator's one impossible step: FootGlitch moves one footfall's foot joints in what the cameras see,
never the ground truth; bad settings are named."""

import numpy as np
import pytest
from gaitcap.simulator import make_trial
from gaitcap.simulator.glitch import FOOT_JOINTS, FootGlitch, glitched_span


def test_only_the_glitched_feet_joints_move_and_only_during_that_footfall():
    glitch = FootGlitch(foot="left", footfall=1, shift_mm=80.0)
    plain = make_trial("clean", seconds=8.0, cameras=3, seed=1)
    bad = make_trial("clean", seconds=8.0, cameras=3, seed=1, glitch=glitch)
    assert np.array_equal(plain.points_mm, bad.points_mm)  # the truth is the real walk
    start, end, towards = glitched_span(glitch, bad.truth)
    assert 0 < start < end and np.linalg.norm(towards) == pytest.approx(1.0)
    shift_px = np.linalg.norm(plain.detections.one_person[..., :2] - bad.detections.one_person[..., :2], axis=-1)
    moved = np.nan_to_num(shift_px) > 0.01  # (C, T, J); measured: the footfall's feet 17 px (median), the rest < 0.001
    frames = (plain.times_s >= start) & (plain.times_s <= end)
    feet = [plain.skeleton.index(f"left_{j}") for j in FOOT_JOINTS]
    others = [j for j in range(plain.skeleton.num_joints) if j not in feet]
    seen = np.isfinite(shift_px)
    assert moved[:, frames][:, :, feet].sum() > 0.9 * seen[:, frames][:, :, feet].sum()
    assert not moved[:, ~frames][:, :, feet].any()
    assert not moved[:, :, others].any()


@pytest.mark.parametrize(("glitch", "words"), [
    (dict(foot="middle"), "FootGlitch.foot: 'left' or 'right', got 'middle'"),
    (dict(footfall=-1), "FootGlitch.footfall: an integer >= 0, got -1"),
    (dict(shift_mm=float("nan")), "FootGlitch.shift_mm: a finite number of mm"),
])
def test_bad_settings_are_named(glitch, words):
    with pytest.raises(ValueError, match=words.replace("(", r"\(").replace(")", r"\)")):
        FootGlitch(**glitch)


def test_a_footfall_the_walk_does_not_have_is_named():
    with pytest.raises(ValueError, match=r"FootGlitch.footfall 99: the walk has only \d+ right footfalls"):
        make_trial("clean", seconds=8.0, cameras=3, seed=1, glitch=FootGlitch(footfall=99))
    with pytest.raises(ValueError, match="glitch must be a FootGlitch or None, got dict"):
        make_trial("clean", seconds=8.0, cameras=3, seed=1, glitch={"foot": "left"})
