import math

import numpy as np
import pytest
from gaitcap.simulator import WalkParams
from gaitcap.simulator.path import SIDE_NAME, plan_walk
from gaitcap.simulator.truth import gait_truth
from gaitcap.simulator.walker import SKELETON, Body, limb_lengths, simulate_body

FPS = 240.0


def _walk(params: WalkParams, seconds: float = 16.0):
    plan = plan_walk(params, seconds)
    times = np.arange(int(seconds * FPS)) / FPS
    body = Body.from_params(params)
    return plan, times, simulate_body(plan, params, times, body), body


VARIABLE = WalkParams(step_length_sd_mm=15.0, step_width_sd_mm=10.0, step_time_sd_s=0.015)


@pytest.fixture(scope="module", params=["normal", "hemiparetic", "variable"])
def walk(request):
    params = {"normal": WalkParams(), "hemiparetic": WalkParams.hemiparetic("left"), "variable": VARIABLE}[request.param]
    return (params, *_walk(params, 24.0 if request.param == "hemiparetic" else 30.0))


def test_limb_lengths_are_constant(walk):
    params, plan, times, pts, body = walk
    lengths = limb_lengths(pts)
    assert np.abs(lengths - lengths[0]).max() < 1e-6
    # every bone of the drawing skeleton that lies within one rigid segment is rigid too
    for a, b in (("left_heel", "left_ankle"), ("right_big_toe", "right_ankle"), ("left_eye", "right_ear")):
        d = np.linalg.norm(pts[:, SKELETON.index(a)] - pts[:, SKELETON.index(b)], axis=-1)
        assert np.ptp(d) < 1e-6


def test_feet_stay_above_the_floor_and_body_upright(walk):
    params, plan, times, pts, body = walk
    assert pts[..., 2].min() > -1e-9
    assert np.all(pts[:, SKELETON.index("head"), 2] > 0.9 * params.height_mm)


def _side_idx(side, name):
    return SKELETON.index(f"{side}_{name}")


def test_heel_stationary_from_foot_flat_to_rise_and_toe_from_flat_to_toe_off(walk):
    params, plan, times, pts, body = walk
    for c in plan.steps:
        side = SIDE_NAME[c.side]
        heel = pts[:, _side_idx(side, "heel")]
        m = (times >= c.t_ff) & (times <= min(c.t_hr, times[-1]))
        assert m.sum() > 5
        assert np.abs(heel[m, :2] - c.heel_xy).max() < 1e-6
        assert np.ptp(heel[m, 2]) < 1e-6
        toe = pts[:, _side_idx(side, "big_toe")]
        m = (times >= c.t_ff) & (times <= min(c.t_to, times[-1]))
        assert np.abs(toe[m] - toe[m][0]).max() < 1e-6


def _speed(points, times):
    return np.linalg.norm(np.gradient(points, times, axis=0), axis=-1)


def test_feet_land_moving_and_roll_to_rest_like_real_feet(walk):
    """At initial contact the contact point is on the floor and still moving forward at 2 roll / loading
    time (real heels: 0.2-1.0 m/s), without a jump in speed; it rests roll mm further on at foot flat."""
    params, plan, times, pts, body = walk
    checked = 0
    for c in plan.steps:
        if not (c.t_hs > 0.1 and c.t_ff < times[-1] - 0.1):
            continue
        side = SIDE_NAME[c.side]
        toe_first = params.side_heel_strike_angle_deg(side) < 0
        point = pts[:, _side_idx(side, "big_toe" if toe_first else "heel")]
        i = int(round(c.t_hs * FPS))
        f = int(np.ceil(c.t_ff * FPS))
        speed = _speed(point, times)
        expected = 2 * params.heel_roll_mm / (c.t_ff - c.t_hs)
        assert speed[i] == pytest.approx(expected, rel=0.05)
        assert 150.0 < speed[i] < 1000.0
        assert abs(speed[i - 1] - speed[i + 1]) < 0.1 * expected  # no jump at contact
        assert point[i, 2] == pytest.approx(point[f, 2], abs=0.5)  # on the floor at contact
        assert np.linalg.norm(point[f, :2] - point[i, :2]) == pytest.approx(params.heel_roll_mm, rel=0.05)
        assert speed[f + 1] < 1e-6
        checked += 1
    assert checked >= 8


def test_contact_types_heel_flat_and_toe_first():
    """Initial contact with the toes up (normal), flat (Parkinsonian shuffle), heel up (paretic foot)."""
    for params, side, sign in ((WalkParams(), "left", 1), (WalkParams.parkinsonian(), "left", 0),
                               (WalkParams.hemiparetic("left"), "left", -1)):
        plan, times, pts, body = _walk(params, 12.0)
        heel, toe = pts[:, _side_idx(side, "heel")], pts[:, _side_idx(side, "big_toe")]
        checked = 0
        for c in plan.steps:
            if SIDE_NAME[c.side] != side or not 0.1 < c.t_hs < c.t_ff < times[-1] - 0.1:
                continue
            i, f = int(round(c.t_hs * FPS)), int(np.ceil(c.t_ff * FPS))
            toes_up = (toe[i, 2] - toe[f, 2]) - (heel[i, 2] - heel[f, 2])
            assert np.sign(round(toes_up)) == sign, (params, toes_up)
            checked += 1
        assert checked >= 2


def test_measured_step_parameters_equal_the_requested_ones(walk):
    params, plan, times, pts, body = walk
    truth = gait_truth(plan, body)
    st = truth.steps
    assert st.straight.sum() >= 8
    # heel positions measured from the trajectory at the stationary phases
    contacts = [c for c in plan.contacts]
    measured = {}
    for k, c in enumerate(contacts):
        side = SIDE_NAME[c.side]
        heel = pts[:, _side_idx(side, "heel"), :2]
        lo = max(c.t_ff, 0.0)  # at rest from foot flat (it rolls there after contact)
        m = (times >= lo) & (times <= min(c.t_hr, times[-1]))
        measured[k] = np.median(heel[m], axis=0)
    step_rows = [k for k, c in enumerate(contacts) if c.kind != "stand"]
    n_checked = 0
    for row, k in enumerate(step_rows):
        if not st.straight[row]:
            continue
        d = st.direction[row, :2]
        side = contacts[k].side
        step = (measured[k] - measured[k - 1]) @ d
        stride = (measured[k] - measured[k - 2]) @ d
        a, b = measured[k - 1], measured[k + 1]
        ab = (b - a) / np.linalg.norm(b - a)
        width = abs(ab[0] * (measured[k] - a)[1] - ab[1] * (measured[k] - a)[0])
        # the ground truth is what the trajectories show ...
        assert st.step_length_mm[row] == pytest.approx(step, abs=1e-6)
        assert st.stride_length_mm[row] == pytest.approx(stride, abs=1e-6)
        assert st.step_width_mm[row] == pytest.approx(width, abs=1e-6)
        assert np.allclose(st.heel_mm[row, :2], measured[k], atol=1e-6)
        if params.step_length_sd_mm == 0 and params.step_width_sd_mm == 0:
            # ... and, without variability, exactly what was asked for
            assert step == pytest.approx(params.side_step_length_mm(SIDE_NAME[side]), abs=1.0)
            assert stride == pytest.approx(2 * params.step_length_mm, abs=1.0)
            assert width == pytest.approx(params.step_width_mm, abs=1.0)
        n_checked += 1
    assert n_checked >= 8


def test_cadence_and_speed_on_straight_passes(walk):
    params, plan, times, pts, body = walk
    s = gait_truth(plan, body).summary()
    tol = 0.02 if params.step_time_sd_s == 0 else 0.05
    assert s["cadence_spm"] == pytest.approx(params.cadence_spm, rel=tol)
    assert s["speed_m_s"] * 1000 == pytest.approx(params.speed_mm_s, rel=tol)
    pelvis = pts[:, SKELETON.index("pelvis")]
    # standing at both ends: the pelvis does not move
    assert np.ptp(pelvis[times < 0.5], axis=0).max() < 1e-6
    assert np.ptp(pelvis[times > times[-1] - 0.5], axis=0).max() < 1e-6


def test_hemiparetic_steps_are_asymmetric():
    params = WalkParams.hemiparetic("left")
    plan, times, pts, body = _walk(params, 24.0)
    st = gait_truth(plan, body).steps
    m = st.straight
    sound = params.short_side
    other = "left" if sound == "right" else "right"
    assert np.allclose(st.step_length_mm[m & (st.foot == sound)], params.side_step_length_mm(sound), atol=1e-6)
    assert np.allclose(st.step_length_mm[m & (st.foot == other)], params.side_step_length_mm(other), atol=1e-6)
    assert params.side_step_length_mm(sound) < params.side_step_length_mm(other)
    # the sound side stands longer: stance fraction of the stride per side
    stance = st.toe_off_s - st.heel_strike_s
    stride = 120.0 / params.cadence_spm
    m = m & np.isfinite(stance)  # the last step of the walk never leaves the floor
    f_sound = np.median(stance[m & (st.foot == sound)]) / stride
    f_other = np.median(stance[m & (st.foot == other)]) / stride
    assert f_sound == pytest.approx(params.side_stance_fraction(sound), abs=0.01)
    assert f_other == pytest.approx(params.side_stance_fraction(other), abs=0.01)


def test_turns_are_marked_and_walk_stays_in_the_room():
    params = WalkParams()
    plan = plan_walk(params, 30.0)
    kinds = [c.kind for c in plan.contacts]
    assert kinds.count("turn") == 2 * params.turn_steps  # three passes, two turns in 30 s
    truth = gait_truth(plan, Body.from_params(params))
    assert np.all(truth.steps.pass_index[truth.steps.kind == "turn"] == -1)
    assert set(np.unique(truth.steps.pass_index)) == {-1, 0, 1, 2}
    xy = np.array([c.heel_xy for c in plan.contacts])
    assert np.all(np.abs(xy) < np.array([3700.0, 4000.0]) - 500)


def test_bad_params_are_named():
    with pytest.raises(ValueError, match="step_length_mm"):
        WalkParams(step_length_mm=50)
    with pytest.raises(ValueError, match="short_side"):
        WalkParams(short_side="middle")
    with pytest.raises(ValueError, match="too short"):
        plan_walk(WalkParams(), 3.0)
    assert WalkParams.from_json(WalkParams.hemiparetic().to_json()) == WalkParams.hemiparetic()
    assert math.isclose(WalkParams().speed_mm_s, 650 * 110 / 60)


def test_variability_is_seeded_and_realised():
    a = plan_walk(VARIABLE, 30.0, seed=1)
    b = plan_walk(VARIABLE, 30.0, seed=1)
    c = plan_walk(VARIABLE, 30.0, seed=2)
    xy = lambda p: np.array([k.heel_xy for k in p.contacts])  # noqa: E731
    assert np.array_equal(xy(a), xy(b)) and xy(a).shape == xy(c).shape and not np.allclose(xy(a), xy(c))
    st = gait_truth(a, Body.from_params(VARIABLE)).steps
    m = st.straight
    assert 8 < np.std(st.step_length_mm[m]) < 40
    assert 4 < np.std(st.step_width_mm[m]) < 30
    assert np.mean(st.step_length_mm[m]) == pytest.approx(VARIABLE.step_length_mm, abs=15)
