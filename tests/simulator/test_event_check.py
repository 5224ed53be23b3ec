"""event_check counts what the truth shows wrong in a gait report, and nothing on the truth's own walk."""

import dataclasses

from gaitcap.reconstruction.gait import analyze_gait
from gaitcap.simulator import make_trial
from gaitcap.simulator.event_check import check_events


def test_the_true_walk_has_no_error_and_wrong_steps_are_counted():
    trial = make_trial("clean", seconds=12.0, cameras=2, seed=0)
    report = analyze_gait(trial.points_mm, trial.times_s, trial.skeleton.joint_names)
    check = check_events(report, trial.truth)
    assert check.truth_errors == 0 and check.steps >= 6, check.problems
    first, second = report.steps[:2]
    wrong = dataclasses.replace(report, steps=(
        dataclasses.replace(first, heel_strike_s=first.heel_strike_s + 0.4),  # no true heel strike there
        dataclasses.replace(second, toe_off_s=second.heel_strike_s + 5.0, step_length_mm=-300.0),
        *report.steps[2:]))
    check = check_events(wrong, trial.truth)
    assert (check.made_up, check.toe_off_outside_stance, check.negative_steps) == (1, 1, 1), check.problems
