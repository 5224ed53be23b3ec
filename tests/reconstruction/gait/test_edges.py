"""The contacts a pass's steps rest on: edges trimmed to what fits, toe offs of their own stance, no event
across a turn; on the demo's kind of recording (a short walk with a turn) against the simulator's truth."""

import math

import numpy as np
import pytest
from gaitcap.reconstruction.gait import TrajectoryQuality, analyze_gait
from gaitcap.reconstruction.gait.bouts import Pass
from gaitcap.reconstruction.gait.edges import EDGE_STEPS, own_stances, pass_contacts, support_contacts
from gaitcap.reconstruction.gait.events import Contact
from gaitcap.reconstruction.triangulation import robust_triangulate
from gaitcap.simulator import make_trial
from gaitcap.simulator.event_check import check_events

STEP_S, STANCE_S = 0.55, 0.68


def _contact(foot: str, hs: float, to: float | None = None) -> Contact:
    return Contact(foot, hs, hs + STANCE_S if to is None else to, (0.0,) * 3, (0.0,) * 3, 1.0, True)


def _walk(start: float, n: int, first: str = "left") -> list[Contact]:
    feet = ("left", "right") if first == "left" else ("right", "left")
    return [_contact(feet[k % 2], start + k * STEP_S) for k in range(n)]


def test_a_made_up_contact_at_the_edge_is_left_out_and_said():
    steady = Pass(0, 2.0, 8.0, (1.0, 0.0), 1200.0)
    wide = Pass(0, 1.0, 9.0, (1.0, 0.0), 1200.0)
    real = _walk(1.5, 13)
    made_up = _contact("right", 1.3, to=2.9)  # a foot shifting before the pass: its "stance" ends 1.6 s later
    kept, left, core = pass_contacts(wide, steady, sorted([made_up, *real], key=lambda c: c.heel_strike_s))
    assert kept == real and [e.contact for e in left] == [made_up]
    assert "1.60 s" in left[0].why or "0.20 s" in left[0].why, left[0].why  # its stance or its step time
    assert (core.start_s, core.end_s) == (steady.start_s, steady.end_s)  # nothing inside the steady part left


def test_contacts_at_the_end_that_break_the_sequence_are_left_out_and_the_pass_ends_before_them():
    steady = Pass(0, 1.0, 8.0, (1.0, 0.0), 1200.0)
    wide = Pass(0, 0.5, 8.5, (1.0, 0.0), 1200.0)
    real = _walk(1.0, 13)  # last heel strike 7.6 s, right
    early = _contact("left", real[-1].heel_strike_s + 0.15, to=real[-1].heel_strike_s + 1.3)  # 0.15 s after
    kept, left, core = pass_contacts(wide, steady, [*real, early])
    assert [e.contact for e in left] == [real[-1], early] or [e.contact for e in left] == [early]
    assert kept[-1].heel_strike_s <= core.end_s <= steady.end_s
    assert all(c.heel_strike_s <= core.end_s for c in kept)


def test_a_misfit_deep_inside_the_pass_is_not_removed():
    steady = Pass(0, 1.0, 10.0, (1.0, 0.0), 1200.0)
    seq = _walk(1.0, 17)
    middle = 8  # 4.4 s from each end: beyond EDGE_STEPS step times
    assert min(seq[middle].heel_strike_s - steady.start_s, steady.end_s - seq[middle].heel_strike_s) > EDGE_STEPS * STEP_S
    broken = seq[:middle] + seq[middle + 1:]  # a contact missed there: two of one foot in a row
    kept, left, _ = pass_contacts(steady, steady, broken)
    assert kept == broken and left == []


def test_a_toe_off_after_the_next_heel_strike_of_that_foot_is_made_unknown():
    a, b = _contact("left", 1.0, to=3.5), _contact("left", 2.1)
    backwards = _contact("right", 1.5, to=1.2)
    out, notes = own_stances([a, backwards, b])
    assert math.isnan(out[0].toe_off_s) and math.isnan(out[1].toe_off_s) and out[2] == b
    assert len(notes) == 2 and "1.00 s" in notes[0] and "3.50 s" in notes[0]


def test_support_phases_use_no_contact_from_before_a_turn():
    wide = Pass(1, 10.0, 16.0, (1.0, 0.0), 1200.0)
    before_turn = _contact("right", 6.0)  # toe off 6.68 s, before the pass
    inside = _walk(10.2, 6)
    assert support_contacts(wide, [before_turn, *inside]) == inside


@pytest.fixture(scope="module")
def short_walk_with_a_turn():
    """12 s of the demo's rig (6 cameras, 15 fps, paper preset) holding a pass, a turn and a pass, robustly
    triangulated (the preliminary stage), with the walk's truth; before ``edges`` it missed a true contact
    inside the first pass and rested a step on a toe off of another stance."""
    trial = make_trial("paper", seconds=30.0, cameras=6, fps=15.0, seed=0)
    det = trial.detections.frames(slice(45, 45 + 180))  # 3-15 s
    result = robust_triangulate(det, trial.rig)
    views = np.asarray(result.quality)
    report = analyze_gait(np.asarray(result.points_mm), det.times_s, trial.skeleton.joint_names,
                          quality=TrajectoryQuality(views, np.full(views.shape, np.nan)))
    return report, trial.truth


def test_events_around_a_turn_match_the_truth(short_walk_with_a_turn):
    report, truth = short_walk_with_a_turn
    turns = [s for s in report.segments if s.kind == "turn" and s.end_s - s.start_s >= 0.5]
    assert len(report.passes) == 2 and turns, report.segments
    turn = turns[0]
    assert report.passes[0].end_s < turn.start_s < turn.end_s < report.passes[1].start_s
    check = check_events(report, truth)
    # no true contact inside a pass missed, no step on a made-up heel strike or on a toe off outside its
    # stance, no negative step; and the steps check has nothing to name at the edges or the turn
    assert check.truth_errors == 0, check.problems
    assert check.missed_contacts == check.dropped_steps == 0, report.left_out
    # no step pairs events across the turn: each pass's steps lie on its side of it
    assert all(s.heel_strike_s < turn.start_s for s in report.steps if s.pass_index == 0)
    assert all(s.heel_strike_s > turn.end_s for s in report.steps if s.pass_index == 1)
    assert sum(s.pass_index == 0 for s in report.steps) >= 4 and sum(s.pass_index == 1 for s in report.steps) >= 2
