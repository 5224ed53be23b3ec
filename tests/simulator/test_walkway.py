import numpy as np
import pytest
from gaitcap.reconstruction.gait import analyze_gait, compare_with_walkway
from gaitcap.reconstruction.skeletons import get_skeleton
from gaitcap.simulator import truth as synthetic
from gaitcap.simulator.params import WalkParams
from gaitcap.simulator.path import plan_walk
from gaitcap.simulator.walker import Body, simulate_body
from gaitcap.simulator.walkway import WalkwayExportParams, make_walkway_export


@pytest.fixture(scope="module")
def trial():
    params = WalkParams()
    plan = plan_walk(params, 24.0)
    times = np.arange(0.0, plan.duration_s, 1 / 30)
    points = simulate_body(plan, params, times)
    truth = synthetic.gait_truth(plan, Body.from_params(params), times[-1])
    return times, points, truth, (lambda t: simulate_body(plan, params, t))


def test_export_holds_straight_footfalls_in_the_walkway_frame(trial):
    _, _, truth, _ = trial
    export = make_walkway_export(truth.steps, params=WalkwayExportParams(position_noise_mm=0.0, time_noise_s=0.0))
    rows = export.step_rows
    assert len(rows) >= 10 and (truth.steps.pass_index[rows] >= 0).all()
    back = truth.steps.heel_mm[rows, :2] - 13.0 * truth.steps.direction[rows, :2]
    assert np.allclose(export.transform.apply(back), export.trial.heel_xy_mm, atol=1e-6)
    assert np.allclose(export.trial.first_contact_s + export.time_offset_s, truth.steps.heel_strike_s[rows])
    # x runs along the walkway: consecutive footfalls of a pass progress mostly in x.
    dx = np.abs(np.diff(export.trial.heel_xy_mm[:, 0]))
    dy = np.abs(np.diff(export.trial.heel_xy_mm[:, 1]))
    assert np.median(dx) > 5 * np.median(dy)


def test_ground_truth_events_and_parameters_are_recovered(trial):
    times, points, truth, sample = trial
    names = get_skeleton("halpe26").joint_names
    report = analyze_gait(points, times, names, sample=sample)
    for side in ("left", "right"):
        true_hs, true_to = truth.heel_strike_s[side], truth.toe_off_s[side]
        for c in report.contacts:
            if c.foot == side and np.isfinite(c.heel_strike_s):
                assert np.min(np.abs(true_hs - c.heel_strike_s)) < 1 / 30
            if c.foot == side and np.isfinite(c.toe_off_s):
                assert np.min(np.abs(true_to - c.toe_off_s)) < 1 / 30
    st = truth.steps
    assert len(report.steps) >= 0.8 * np.sum(st.pass_index >= 0)
    for s in report.steps:
        k = int(np.argmin(np.abs(st.heel_strike_s - s.heel_strike_s)))
        assert st.foot[k] == s.foot
        assert s.step_length_mm == pytest.approx(st.step_length_mm[k], abs=1.0)
        if np.isfinite(s.stride_length_mm):
            assert s.stride_length_mm == pytest.approx(st.stride_length_mm[k], abs=1.0)
        if np.isfinite(s.step_width_mm):
            assert s.step_width_mm == pytest.approx(st.step_width_mm[k], abs=1.0)
        assert np.allclose(s.heel_mm, st.heel_mm[k], atol=1.0)


def test_alignment_recovers_the_walkway_and_leaves_noise_level_residuals(trial):
    times, points, truth, _ = trial
    export = make_walkway_export(truth.steps, params=WalkwayExportParams(seed=3))
    names = get_skeleton("halpe26").joint_names
    result = compare_with_walkway([(points, times, names)], [export.trial])
    assert result.offsets_s["0"] == pytest.approx(export.time_offset_s, abs=0.03)
    assert result.transform.scale == pytest.approx(export.transform.scale, abs=1e-3)
    assert abs(result.transform.rotation_rad - export.transform.rotation_rad) < 2e-3
    assert result.forward_bias_mm == pytest.approx(13.0, abs=1.5)
    res = result.residuals
    assert res["heel_forward_mm"].mean == pytest.approx(13.0, abs=1.5)  # the pressure-vs-vision offset
    for name in ("heel_forward_mm", "heel_lateral_mm", "toe_lateral_mm", "step_length_mm", "step_width_mm"):
        assert res[name].n >= 10
        assert res[name].sigma_iqr < 5.0, name  # noise is 2 mm per point
    for name in ("heel_lateral_mm", "step_length_mm", "stride_length_mm", "step_width_mm"):
        assert abs(res[name].mean) < 2.0, name
    # Footfalls brought back to the kinematic frame and clock land on the true heel strikes.
    rows = {r.first_contact_s: r for r in result.contacts}
    for k, first in zip(export.step_rows, export.trial.first_contact_s, strict=True):
        r = rows[float(first)]
        assert abs(r.kinematic_time_s - truth.steps.heel_strike_s[k]) < 0.05
        assert np.linalg.norm(np.asarray(r.walkway_heel_in_kinematic_mm) - truth.steps.heel_mm[k, :2]) < 25.0


def test_session_of_two_trials_shares_one_transform(trial):
    times, points, truth, _ = trial
    params = WalkParams(step_length_mm=560.0, step_width_mm=140.0)
    plan = plan_walk(params, 16.0)
    times2 = np.arange(0.0, plan.duration_s, 1 / 30)
    points2 = simulate_body(plan, params, times2)
    truth2 = synthetic.gait_truth(plan, Body.from_params(params), times2[-1])
    first = make_walkway_export(truth.steps, name="a", params=WalkwayExportParams(seed=5))
    second = make_walkway_export(truth2.steps, name="b", params=WalkwayExportParams(seed=6),
                                 transform=first.transform)
    names = get_skeleton("halpe26").joint_names
    result = compare_with_walkway([(points, times, names), (points2, times2, names)],
                                  [first.trial, second.trial])
    assert result.offsets_s["a"] == pytest.approx(first.time_offset_s, abs=0.03)
    assert result.offsets_s["b"] == pytest.approx(second.time_offset_s, abs=0.03)
    assert result.transform.scale == pytest.approx(first.transform.scale, abs=1e-3)
    assert {r.trial for r in result.contacts} == {"a", "b"}
    assert result.residuals["step_width_mm"].sigma_iqr < 5.0


def test_ground_truth_frames_alone_give_events_within_a_frame(trial):
    times, points, truth, _ = trial
    report = analyze_gait(points, times, get_skeleton("halpe26").joint_names)  # 30 fps frames, no function
    in_pass = [c for c in report.contacts if any(p.contains(c.heel_strike_s) for p in report.passes)]
    assert len(in_pass) >= 10
    for c in in_pass:
        assert np.min(np.abs(truth.heel_strike_s[c.foot] - c.heel_strike_s)) < 1 / 30
        if np.isfinite(c.toe_off_s):
            assert np.min(np.abs(truth.toe_off_s[c.foot] - c.toe_off_s)) < 1 / 30
    for s in report.steps:
        k = int(np.argmin(np.abs(truth.steps.heel_strike_s - s.heel_strike_s)))
        assert s.step_length_mm == pytest.approx(truth.steps.step_length_mm[k], abs=1.0)
