import math

import numpy as np
import pytest
from gaitcap.acquisition.readers import read_walkway_csv
from gaitcap.acquisition.writers import write_walkway_csv
from gaitcap.reconstruction.gait import compare_with_walkway, walkway_from_csv_text
from gaitcap.reconstruction.gait.walkway import (
    ResidualStats,
    Similarity2D,
    WalkwayTrial,
    fit_similarity,
    walkway_passes,
)


def test_similarity_fit_recovers_a_transform_and_clips_scale():
    rng = np.random.default_rng(1)
    src = rng.uniform(-3000, 3000, (20, 2))
    true = Similarity2D(1.012, 0.7, (150.0, -40.0))
    fit = fit_similarity(src, true.apply(src), scale_min=0.9, scale_max=1.1)
    assert fit.scale == pytest.approx(1.012, abs=1e-9) and fit.rotation_rad == pytest.approx(0.7, abs=1e-9)
    assert np.allclose(fit.inverse(true.apply(src)), src)
    clipped = fit_similarity(src, Similarity2D(1.5, 0.0, (0, 0)).apply(src), scale_min=0.9, scale_max=1.1)
    assert clipped.scale == pytest.approx(1.1)


def test_residual_stats():
    x = [1.0, 2.0, 3.0, 4.0, float("nan")]
    s = ResidualStats.of(x)
    assert s.n == 4 and s.mean == 2.5 and s.rmse == pytest.approx(math.sqrt(7.5))
    assert s.sigma_iqr == pytest.approx(0.7413 * 1.5)


def _trial(name="t1"):
    heels = np.array([[0, 70], [650, -70], [1300, 70], [1950, -70], [1900, 500], [1250, 640], [600, 500]], float)
    feet = ("left", "right", "left", "right", "left", "right", "left")
    first = np.array([1.0, 1.55, 2.1, 2.65, 6.0, 6.55, 7.1])
    return WalkwayTrial(name, feet, first, first + 0.7, heels, heels + [200, 0])


def test_csv_round_trip_and_passes(tmp_path):
    path = tmp_path / "walkway.csv"
    write_walkway_csv([_trial("a"), _trial("b")], path)
    trials = read_walkway_csv(path)
    assert [t.name for t in trials] == ["a", "b"]
    assert np.allclose(trials[0].heel_xy_mm, _trial().heel_xy_mm)
    assert [len(p) for p in walkway_passes(trials[0])] == [4, 3]


@pytest.mark.parametrize("text, message", [
    ("foot,first_contact_s\nleft,1\n", "lacks column"),
    ("foot,first_contact_s,last_contact_s,heel_x_mm,heel_y_mm,toe_x_mm,toe_y_mm\nup,1,2,0,0,0,0\n", "foot"),
    ("foot,first_contact_s,last_contact_s,heel_x_mm,heel_y_mm,toe_x_mm,toe_y_mm\nL,1,x,0,0,0,0\n", "number"),
    ("foot,first_contact_s,last_contact_s,heel_x_mm,heel_y_mm,toe_x_mm,toe_y_mm\nL,2,1,0,0,0,0\n", "ends before"),
])
def test_bad_csv_is_refused_with_a_clear_message(text, message):
    with pytest.raises(ValueError, match=f"bad.csv(:2)?: .*{message}"):
        walkway_from_csv_text(text, source="bad.csv")


def test_alignment_on_the_analytic_walker(walker):
    # Legs of different lengths: a symmetric U would match itself rotated by 180 degrees.
    walk = walker(segments=(("line", 5000), ("arc", 500, 180), ("line", 3200)))
    true = Similarity2D(0.99, 1.1, (500.0, 2000.0))
    offset = 1.3
    first_leg, second_leg = walk.arc_mm < 4500, walk.arc_mm > 5000 + np.pi * 500 + 500  # off the turn
    keep = np.isfinite(walk.hs_s) & np.isfinite(walk.to_s) & (first_leg | second_leg)
    forward = np.array([[np.cos(np.radians(30)), np.sin(np.radians(30))]])
    direction = np.where(first_leg[:, None], 1.0, -1.0) * forward
    heels = true.apply(walk.heels_mm - 13.0 * direction)[keep]
    toes = true.apply(walk.heels_mm + 230.0 * direction - 13.0 * direction)[keep]
    trial = WalkwayTrial("0", tuple(np.array(walk.feet)[keep]), walk.hs_s[keep] - offset,
                         walk.to_s[keep] - offset, heels, toes)
    result = compare_with_walkway([(walk.points_mm, walk.times_s, walk.joint_names)], [trial])
    # Few footfalls here: only the clock is checked; accuracy is checked on the synthetic world
    # (tests/simulator/test_walkway.py).
    assert result.offsets_s["0"] == pytest.approx(offset, abs=0.05)
    assert result.transform.scale == pytest.approx(0.99, abs=0.01)
