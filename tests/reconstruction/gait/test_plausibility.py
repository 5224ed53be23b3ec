"""Steps that deserve to be counted: out-of-order events, a broken left/right sequence and values beyond
3.5 robust SD of the patient's own steps are excluded with the reason and left out of the summary."""

import numpy as np
import pytest
from gaitcap.reconstruction.gait.bouts import Pass
from gaitcap.reconstruction.gait.events import Contact
from gaitcap.reconstruction.gait.parameters import STEP_PARAMETERS, Step, pass_steps, summarise
from gaitcap.reconstruction.gait.plausibility import (
    implausible_heel_frames,
    outliers,
    time_precision_s,
    with_exclusions,
)

# the issue's refined trial: right step widths 92-110 mm and one of 1.2 mm
WIDTHS = {"left": [99, 104, 95, 101, 97, 100, 98, 99], "right": [92, 95, 110, 1.2, 97, 93, 96, 100]}


def _step(i: int, foot: str, **values) -> Step:
    params = dict.fromkeys(STEP_PARAMETERS, float("nan")) | values
    return Step(i, 0, foot, 0.55 * i, 0.55 * i + 0.68, (0.0,) * 3, (0.0,) * 3, confidence=1.0, **params)


def _alternating(**series) -> list[Step]:
    """Steps left, right, left, ... with each named parameter's values per side in order."""
    n = len(next(iter(series.values()))["left"])
    out = []
    for k in range(n):
        for foot in ("left", "right"):
            out.append(_step(len(out), foot, **{name: v[foot][k] for name, v in series.items()}))
    return out


def test_the_issues_one_step_width_of_1_mm_is_excluded_with_its_reason_and_left_out_of_the_summary():
    steps = _alternating(step_width_mm=WIDTHS, step_length_mm={"left": [650.0] * 8, "right": [640.0] * 8})
    found = outliers(steps)
    bad = next(i for i, s in enumerate(steps) if s.step_width_mm == 1.2)
    assert list(found) == [bad]
    assert found[bad].startswith("step width 1 mm is ") and "robust SD from this patient's" in found[bad]
    marked = with_exclusions(steps, [True] * len(steps), {})
    assert [s.excluded != "" for s in marked] == [i == bad for i in range(len(steps))]
    summary = summarise(marked, 1)
    width = summary.parameters["step_width_mm"]
    assert width["right"].n == 7 and width["right"].mean == pytest.approx(np.mean([w for w in WIDTHS["right"] if w > 2]))
    assert summary.asymmetry_pct["step_width_mm"] < 5 and summary.num_excluded_steps == 1
    # counted in the summary the 1.2 mm step made the issue's side difference (SI over 10 %)
    assert summarise(steps, 1).asymmetry_pct["step_width_mm"] > 10


def test_a_misplaced_heel_strike_makes_one_step_long_and_the_next_short_and_both_are_excluded():
    """The issue's preliminary walk: step times 0.977 and 0.174 s among steps of about 0.55 s."""
    times = {"left": [0.55, 0.54, 0.977, 0.56, 0.55, 0.55], "right": [0.54, 0.55, 0.174, 0.55, 0.56, 0.54]}
    steps = _alternating(step_time_s=times)
    found = outliers(steps, resolution_s=1 / 30)
    assert sorted(steps[i].step_time_s for i in found) == [0.174, 0.977]
    assert all(r.startswith("step time ") for r in found.values())


def test_variation_within_the_events_resolution_or_a_few_mm_is_never_an_outlier():
    """Identical steps but two: one 55 ms longer, one 25 mm wider. At a 30 fps frame grid (the preliminary
    stage's events) 55 ms is within 3.5 x one frame; on a continuous fit (1 ms) it is beyond 3.5 x the
    10 ms floor; 25 mm is within 3.5 x the 10 mm floor. With fewer than 5 steps nothing is judged."""
    steps = _alternating(step_time_s={"left": [0.545] * 5 + [0.600], "right": [0.545] * 6},
                         step_width_mm={"left": [100.0] * 6, "right": [100.0] * 5 + [125.0]})
    assert outliers(steps, resolution_s=1 / 30) == {}
    found = outliers(steps, resolution_s=0.001)
    assert list(found) == [10] and found[10].startswith("step time 0.600 s is 5.5 robust SD")
    assert outliers(steps[:4], resolution_s=0.001) == {}


def test_events_between_frames_are_timed_to_half_a_frame_so_a_step_within_a_few_of_those_is_not_excluded():
    """The demo's refined trials (15 fps, a continuous fit, events searched to 1 ms): their step times
    scatter around the truth by about half a frame (bench/gait_edges.py, docs/benchmarks.md), so a step
    45 ms off the others is measurement, and one whose heel strike is 150 ms late is not."""
    assert time_precision_s(1 / 15, 0.001) == pytest.approx(1 / 30)
    assert time_precision_s(1 / 30, 1 / 30) == pytest.approx(1 / 30)  # events on the frames: one frame
    assert time_precision_s(1 / 100, 0.001) == pytest.approx(0.005)  # below the 10 ms floor then
    near = {"left": [0.545, 0.55, 0.54, 0.59, 0.545, 0.55], "right": [0.55, 0.545, 0.54, 0.55, 0.545, 0.55]}
    precision = time_precision_s(1 / 15, 0.001)
    assert outliers(_alternating(step_time_s=near), resolution_s=precision) == {}
    assert list(outliers(_alternating(step_time_s=near), resolution_s=0.001)) == [6]  # the old 10 ms floor
    late = {"left": near["left"][:3] + [0.695] + near["left"][4:], "right": near["right"]}
    found = outliers(_alternating(step_time_s=late), resolution_s=precision)
    assert list(found) == [6] and found[6].startswith("step time 0.695 s is ")


def test_sides_are_judged_by_their_own_median():
    """A hemiparetic patient's short and long steps are both that patient's gait: none is excluded."""
    lengths = {"left": [552.0, 548.0, 556.0, 550.0, 551.0], "right": [408.0, 404.0, 411.0, 407.0, 409.0]}
    assert outliers(_alternating(step_length_mm=lengths)) == {}


def _contact(foot, hs, to, x_mm):
    return Contact(foot, hs, to, (x_mm, 100.0 if foot == "left" else 0.0, 0.0), (x_mm + 200, 0.0, 0.0), 0.0, True)


def test_events_out_of_order_and_a_broken_left_right_sequence_exclude_the_step_saying_why():
    walk = Pass(0, 0.0, 10.0, (1.0, 0.0), 1200.0)
    contacts = [_contact("left", 1.0, 1.7, 0.0), _contact("right", 1.55, 2.25, 650.0),
                _contact("left", 2.1, 2.8, 1300.0), _contact("left", 2.9, 3.5, 1400.0),  # two lefts in a row
                _contact("right", 3.4, 4.1, 2000.0), _contact("left", 3.95, 4.65, 2650.0),
                _contact("right", 4.5, 4.45, 3300.0),  # toe off before its heel strike
                _contact("left", 5.05, 5.75, 3950.0)]
    steps, left_out = pass_steps(walk, contacts, contacts, {})
    assert [(o.what, o.foot, o.time_s) for o in left_out] == [("missed contact", "left", 2.9)]
    why = {(s.foot, s.heel_strike_s): s.excluded for s in steps}
    assert why[("right", 3.4)] == ("left/right sequence broken: measured from the second of two left contacts in a "
                                   "row (2.10 s and 2.90 s)")
    assert why[("right", 4.5)] == "events out of order: toe off (4.45 s) not after heel strike (4.50 s)"
    assert why[("left", 3.95)] == "" and why[("right", 1.55)] == ""
    summary = summarise(steps, 1)  # the first and last step are edge steps, the two excluded are not counted
    assert (summary.num_steps, summary.num_edge_steps, summary.num_excluded_steps) == (6, 2, 2)
    assert summary.parameters["step_length_mm"]["all"].n == 2


def test_a_heel_below_the_floor_or_that_fewer_than_two_views_agree_on_is_implausible():
    z = np.array([60.0, 250.0, -500.0, np.nan, 900.0, -40.0, 70.0])
    assert implausible_heel_frames(z).tolist() == [False, False, True, False, True, False, False]
    views = np.array([5.0, 3.0, 4.0, 0.0, 6.0, 2.0, 1.4])
    assert implausible_heel_frames(z, views).tolist() == [False, False, True, False, True, False, True]


def test_a_step_excluded_for_its_events_keeps_that_reason_and_is_no_reference_for_the_others():
    steps = _alternating(step_time_s={"left": [0.55, 0.54, 0.56, 0.55, 0.55], "right": [0.54, 0.55, 0.55, 0.56, 0.55]})
    steps[4] = _step(4, "left", step_time_s=3.0, excluded="events out of order: toe off (2.10 s) not after heel strike (2.20 s)")
    marked = with_exclusions(steps, [True] * len(steps), {}, resolution_s=1 / 30)
    assert [s.excluded for s in marked] == [""] * 4 + [steps[4].excluded] + [""] * 5
