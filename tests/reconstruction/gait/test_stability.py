"""Leave-one-out of a trial's summary numbers: a side difference or a value outside a range holds only with
enough counted steps a side and whichever single step is left out."""

import math

import numpy as np
import pytest
from gaitcap.reconstruction.gait import analyze_gait
from gaitcap.reconstruction.gait.stability import MIN_STEPS_PER_SIDE, leave_one_out, symmetry_index_pct
from gaitcap.reconstruction.skeletons import get_skeleton
from gaitcap.simulator.params import WalkParams
from gaitcap.simulator.path import Room, plan_walk
from gaitcap.simulator.walker import simulate_body

# the issue's refined trial: right step widths 92-110 mm and one of 1.2 mm (left 99, right 88 mm, SI 11.4 %)
WIDTHS = {"left": [99, 104, 95, 101, 97, 100, 98, 99], "right": [92, 95, 110, 1.2, 97, 93, 96, 100]}


def _steps(values: dict[str, list[float]], name: str = "step_width_mm", **extra) -> list[dict]:
    out = []
    for k in range(max(map(len, values.values()))):
        for foot in ("left", "right"):
            if k < len(values[foot]):
                out.append({"foot": foot, "steady": True, "excluded": "", name: values[foot][k], **extra})
    return out


def test_the_issues_side_difference_rests_on_one_step_and_does_not_hold():
    held = leave_one_out(_steps(WIDTHS))["step_width_mm"]
    assert (held.n_left, held.n_right) == (8, 8) and held.enough
    assert held.left == pytest.approx(np.mean(WIDTHS["left"])) and held.right == pytest.approx(np.mean(WIDTHS["right"]))
    assert symmetry_index_pct(held.left, held.right) > 10  # what the issue's page called a finding
    lo, hi = held.si_range
    assert lo < 5 < 10 < hi and not held.side_difference_holds(10.0)


def test_a_real_side_difference_holds_whichever_step_is_left_out():
    steps = _steps({"left": [552.0, 548, 556, 550, 551], "right": [408.0, 404, 411, 407, 409]}, "step_length_mm")
    held = leave_one_out(steps)["step_length_mm"]
    assert held.side_difference_holds(10.0) and held.si_range[0] > 29


def test_too_few_counted_steps_a_side_make_no_finding_however_large_the_difference():
    steps = _steps({"left": [552.0, 548, 556, 550, 551], "right": [408.0, 404, 411]}, "step_length_mm")
    held = leave_one_out(steps)["step_length_mm"]
    assert (held.n_left, held.n_right) == (5, MIN_STEPS_PER_SIDE - 1) and not held.enough
    assert not held.side_difference_holds(10.0)


def test_excluded_and_edge_steps_are_not_counted():
    steps = _steps(WIDTHS)
    for s in steps:
        if s["step_width_mm"] == 1.2:
            s["excluded"] = "step width 1 mm is 14.8 robust SD from this patient's 96 mm (limit 3.5)"
    steps.append({"foot": "right", "steady": False, "excluded": "", "step_width_mm": 400.0})
    held = leave_one_out(steps)["step_width_mm"]
    assert held.n_right == 7 and held.right == pytest.approx(np.mean([w for w in WIDTHS["right"] if w > 2]))
    assert held.si_range[1] < 10


def test_a_value_outside_a_range_must_stay_outside_whichever_step_is_left_out():
    """Step times around 0.55 s against a range ending at 0.60 s: one very long step pulls the mean out of
    it, so leaving it out brings it back in (no finding); a slow walker is outside with every step."""
    def outside(value):  # a range of 0.40-0.60 s
        return -1 if value < 0.40 else (1 if value > 0.60 else 0)

    one_long = _steps({"left": [0.55, 0.56, 0.54, 1.60], "right": [0.55, 0.54, 0.56, 0.55]}, "step_time_s")
    held = leave_one_out(one_long)["step_time_s"]
    assert outside(held.mean) == 1 and not held.beyond(outside)
    slow = _steps({"left": [0.68, 0.70, 0.66, 0.71], "right": [0.69, 0.67, 0.70, 0.72]}, "step_time_s")
    assert leave_one_out(slow)["step_time_s"].beyond(outside)
    cadence = leave_one_out(slow)["cadence_steps_min"]  # 60 / mean step time, per side from that side's
    assert cadence.mean == pytest.approx(60 / np.mean([0.68, 0.70, 0.66, 0.71, 0.69, 0.67, 0.70, 0.72]))
    assert cadence.left == pytest.approx(60 / np.mean([0.68, 0.70, 0.66, 0.71]))


def test_the_counted_steps_of_a_gait_report_give_its_summary_back():
    """What the findings test rests on is the summary the report shows: per side, pooled, cadence, speed."""
    names, times, params = list(get_skeleton("halpe26").joint_names), np.arange(300) / 30.0, WalkParams()
    report = analyze_gait(simulate_body(plan_walk(params, 10.0, Room(), seed=0), params, times), times, names).to_dict()
    held, summary = leave_one_out(report["steps"]), report["summary"]
    for name, groups in summary["parameters"].items():
        assert held[name].agrees(left=groups["left"]["mean"], right=groups["right"]["mean"],
                                 mean=groups["all"]["mean"]), name
    assert held["cadence_steps_min"].agrees(left=math.nan, right=math.nan, mean=summary["cadence_steps_min"])
    assert held["gait_speed_m_s"].agrees(left=math.nan, right=math.nan, mean=summary["gait_speed_m_s"])
    assert not held["step_length_mm"].agrees(left=math.nan, right=math.nan, mean=summary["gait_speed_m_s"])
