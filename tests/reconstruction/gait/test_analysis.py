import csv
import io

import numpy as np
import pytest
from gaitcap.reconstruction.gait import GaitConfig, TrajectoryQuality, analyze_gait
from gaitcap.reconstruction.gait.events import contact_distance
from gaitcap.simulator import make_trial
from gaitcap.simulator.params import WalkParams


def _match(report, walk):
    """Detected contacts matched to the walker's by heel position: list of (contact, k)."""
    out = []
    for c in report.contacts:
        d = np.linalg.norm(walk.heels_mm - np.asarray(c.heel_mm[:2]), axis=1)
        k = int(np.argmin(d))
        assert d[k] < 1.0 and walk.feet[k] == c.foot
        out.append((c, k))
    return out


def test_straight_walk_events_and_parameters(walker):
    walk = walker()
    report = analyze_gait(walk.points_mm, walk.times_s, walk.joint_names)
    assert len(report.passes) == 1
    d = np.radians(30.0)
    assert np.allclose(report.passes[0].direction, [np.cos(d), np.sin(d)], atol=1e-6)
    matched = _match(report, walk)
    assert len(matched) == len(walk.feet)
    for c, k in matched:
        if np.isfinite(walk.hs_s[k]):
            assert abs(c.heel_strike_s - walk.hs_s[k]) < 1 / 30
        if np.isfinite(walk.to_s[k]):
            assert abs(c.toe_off_s - walk.to_s[k]) < 1 / 30
    assert len(report.steps) >= 6
    for s in report.steps:
        assert s.step_length_mm == pytest.approx(650.0, abs=1.0)
        assert np.isnan(s.stride_length_mm) or s.stride_length_mm == pytest.approx(1300.0, abs=1.0)
        assert np.isnan(s.step_width_mm) or s.step_width_mm == pytest.approx(140.0, abs=1.0)
        assert np.isnan(s.step_time_s) or s.step_time_s == pytest.approx(0.55, abs=1 / 30)
        assert np.isnan(s.stance_pct) or s.stance_pct == pytest.approx(62.0, abs=100 / 30 / 1.1)
    summary = report.summary
    assert summary.cadence_steps_min == pytest.approx(60 / 0.55, rel=0.01)
    assert summary.gait_speed_m_s == pytest.approx(1.3 / 1.1, rel=0.01)
    assert summary.parameters["step_length_mm"]["left"].n >= 2
    assert summary.asymmetry_pct["step_length_mm"] < 0.5


def test_continuous_sampler_gives_sub_frame_events(walker):
    walk = walker()
    report = analyze_gait(walk.points_mm, walk.times_s, walk.joint_names, sample=walk.sample)
    errors = [c.heel_strike_s - walk.hs_s[k] for c, k in _match(report, walk) if np.isfinite(walk.hs_s[k])]
    # Landing at 0.9 m/s that rolls 35 mm to rest: detected when within 30 mm (25 ms of walking at
    # 1.18 m/s), a few ms late.
    assert max(abs(e) for e in errors) < 0.015


def test_reports_say_how_finely_their_events_are_located(walker):
    """A continuous trajectory gives sub-frame events (1 ms search), frames alone one frame interval."""
    walk = walker()
    fine = analyze_gait(walk.points_mm, walk.times_s, walk.joint_names, sample=walk.sample).timing
    frames = analyze_gait(walk.points_mm, walk.times_s, walk.joint_names).timing
    dt = float(np.median(np.diff(walk.times_s)))
    assert fine.located_on == "continuous trajectory" and fine.sub_frame and fine.resolution_s == 0.001
    assert frames.located_on == "spline through frames" and not frames.sub_frame
    assert frames.resolution_s == pytest.approx(dt) and frames.frame_interval_s == pytest.approx(dt)
    report = analyze_gait(walk.points_mm, walk.times_s, walk.joint_names)
    assert report.to_dict()["timing"]["resolution_s"] == pytest.approx(dt)
    assert fine.to_dict()["sub_frame"] is True


def test_u_turn_splits_passes_and_excludes_turn_steps(walker):
    walk = walker(segments=(("line", 5000), ("arc", 500, 180), ("line", 5000)))
    report = analyze_gait(walk.points_mm, walk.times_s, walk.joint_names)
    assert len(report.passes) == 2
    assert np.dot(report.passes[0].direction, report.passes[1].direction) < -0.99
    assert any(s.kind == "turn" for s in report.segments)
    assert any(w.startswith("turns") for w in report.warnings)
    for s in report.steps:
        assert s.step_length_mm == pytest.approx(650.0, abs=1.0)
        assert np.isnan(s.step_width_mm) or s.step_width_mm == pytest.approx(140.0, abs=1.0)
    assert {s.pass_index for s in report.steps} == {0, 1}


def test_turn_in_the_middle_of_a_pass_gives_no_bogus_steps(walker):
    walk = walker(segments=(("line", 4000), ("arc", 600, 90), ("line", 4000)))
    report = analyze_gait(walk.points_mm, walk.times_s, walk.joint_names)
    assert len(report.passes) == 2
    for s in report.steps:
        assert s.step_length_mm == pytest.approx(650.0, abs=1.0)


def test_standing_only_is_refused(walker):
    walk = walker()
    still = np.repeat(walk.points_mm[:1], len(walk.times_s), axis=0)
    with pytest.raises(ValueError, match="standing only"):
        analyze_gait(still, walk.times_s, walk.joint_names)


def test_short_trial_and_missing_joints_are_refused(walker):
    walk = walker()
    with pytest.raises(ValueError, match="too short"):
        analyze_gait(walk.points_mm[:20], walk.times_s[:20], walk.joint_names)
    names = tuple("nose" if n == "left_heel" else n for n in walk.joint_names)
    with pytest.raises(ValueError, match="left_heel"):
        analyze_gait(walk.points_mm, walk.times_s, names)


def test_long_nan_gap_drops_contacts_there(walker):
    walk = walker(segments=(("line", 8000),))
    points = walk.points_mm.copy()
    gap = (walk.times_s > 3.0) & (walk.times_s < 4.0)
    points[gap, 4] = np.nan
    report = analyze_gait(points, walk.times_s, walk.joint_names)
    assert any("gap" in w for w in report.warnings)
    left = [c for c in report.contacts if c.valid and c.foot == "left"]
    for c in left:  # only the left heel is missing
        assert not (2.9 < c.heel_strike_s < 4.1) and not (2.9 < c.toe_off_s < 4.1)
    assert any(c.valid and c.foot == "right" and 2.9 < c.heel_strike_s < 4.1 for c in report.contacts)
    for s in report.steps:
        assert s.step_length_mm == pytest.approx(650.0, abs=1.0)
    # A short gap is interpolated and changes nothing.
    points = walk.points_mm.copy()
    points[(walk.times_s > 3.0) & (walk.times_s < 3.1), 4] = np.nan
    assert len(analyze_gait(points, walk.times_s, walk.joint_names).steps) > 6


def test_noisy_reconstruction_keeps_events_within_a_frame(walker):
    walk = walker(segments=(("line", 8000),))
    rng = np.random.default_rng(0)
    noisy = walk.points_mm + rng.normal(0, 3.0, walk.points_mm.shape)
    report = analyze_gait(noisy, walk.times_s, walk.joint_names)  # noise-adaptive defaults
    matched = _match_loose(report, walk)
    assert len(matched) >= len(walk.feet) - 1
    for c, k in matched:
        if np.isfinite(walk.hs_s[k]) and np.isfinite(c.heel_strike_s):
            assert abs(c.heel_strike_s - walk.hs_s[k]) < 1 / 30
    for s in report.steps:
        assert s.step_length_mm == pytest.approx(650.0, abs=6.0)


def _match_loose(report, walk):
    out = []
    for c in report.contacts:
        d = np.linalg.norm(walk.heels_mm - np.asarray(c.heel_mm[:2]), axis=1)
        k = int(np.argmin(d))
        assert d[k] < 10.0 and walk.feet[k] == c.foot
        out.append((c, k))
    return out


def test_quality_lowers_confidence(walker):
    walk = walker()
    t, j = walk.points_mm.shape[:2]
    good = TrajectoryQuality(np.full((t, j), 6), np.full((t, j), 2.0))
    bad = TrajectoryQuality(np.full((t, j), 1), np.full((t, j), 30.0))
    c_good = analyze_gait(walk.points_mm, walk.times_s, walk.joint_names, quality=good).steps[0].confidence
    c_bad = analyze_gait(walk.points_mm, walk.times_s, walk.joint_names, quality=bad).steps[0].confidence
    assert 0.7 < c_good <= 1.0 and c_bad < 0.1


def test_a_foot_placed_backwards_gives_no_bogus_step(walker):
    walk = walker(segments=(("line", 8000),))
    points = walk.points_mm.copy()
    # Move one right contact 900 mm back along the path (a mislabelled / swapped foot).
    k = 5
    back = -900.0 * np.array([np.cos(np.radians(30)), np.sin(np.radians(30))])
    stance = (walk.times_s >= walk.hs_s[k] - 0.2) & (walk.times_s <= walk.to_s[k] + 0.2)
    points[stance, 5, :2] += back
    points[stance, 7, :2] += back
    report = analyze_gait(points, walk.times_s, walk.joint_names)
    assert any("dropped" in w for w in report.warnings)
    for s in report.steps:
        assert 0 < s.step_length_mm < 1500


def test_noisy_body_centre_still_gives_the_passes(walker):
    walk = walker(segments=(("line", 5000), ("arc", 500, 180), ("line", 5000)))
    points = walk.points_mm.copy()
    points[:, :2] += np.random.default_rng(1).normal(0, 25.0, points[:, :2].shape)  # hips only
    report = analyze_gait(points, walk.times_s, walk.joint_names)
    assert len(report.passes) == 2
    assert len(report.steps) >= 8


def test_any_skeleton_with_heels_and_toes(walker):
    from gaitcap.reconstruction.skeletons import get_skeleton

    walk = walker()
    mediapipe = tuple(n.replace("big_toe", "foot_index") for n in walk.joint_names)
    assert all(n in get_skeleton("mediapipe33").joint_names for n in mediapipe)
    steps = analyze_gait(walk.points_mm, walk.times_s, mediapipe).steps
    assert len(steps) >= 6 and all(abs(s.step_length_mm - 650.0) < 1.0 for s in steps)
    coco = get_skeleton("coco17").joint_names
    with pytest.raises(ValueError, match="heel"):
        analyze_gait(np.zeros((100, len(coco), 3)), np.arange(100) / 30.0, coco)


def test_edge_steps_are_reported_and_left_out_of_the_summary(walker):
    walk = walker()
    report = analyze_gait(walk.points_mm, walk.times_s, walk.joint_names, sample=walk.sample)
    steps = report.steps
    assert not steps[0].steady and not steps[-1].steady and all(s.steady for s in steps[1:-1])
    assert report.summary.num_edge_steps == 2 and report.summary.num_steps == len(steps)
    assert report.summary.parameters["step_length_mm"]["all"].n == len(steps) - 2
    rows = list(csv.DictReader(io.StringIO(report.to_csv())))
    assert [r["steady"] for r in rows] == [str(int(s.steady)) for s in steps]


def test_per_side_summary_and_symmetry_index_of_a_hemiparetic_walk():
    """Every parameter per side (n, mean, SD, CV) with the symmetry index 100 |L - R| / mean(L, R), in the
    JSON and the summary CSV: the hemiparetic walker's 15 % step asymmetry gives SI 30 %."""
    from gaitcap.reconstruction.gait.parameters import STEP_PARAMETERS
    from gaitcap.reconstruction.skeletons import get_skeleton
    from gaitcap.simulator.params import WalkParams
    from gaitcap.simulator.path import plan_walk
    from gaitcap.simulator.walker import simulate_body

    params = WalkParams.hemiparetic("left")
    plan = plan_walk(params, 24.0)
    times = np.arange(0.0, plan.duration_s, 1 / 30)
    report = analyze_gait(simulate_body(plan, params, times), times, get_skeleton("halpe26").joint_names)
    summary = report.summary
    left, right = (summary.parameters["step_length_mm"][s].mean for s in ("left", "right"))
    assert left == pytest.approx(params.side_step_length_mm("left"), abs=2.0)
    assert right == pytest.approx(params.side_step_length_mm("right"), abs=2.0)
    assert summary.asymmetry_pct["step_length_mm"] == pytest.approx(30.0, abs=0.5)
    assert summary.parameters["stance_pct"]["right"].mean > summary.parameters["stance_pct"]["left"].mean
    rows = list(csv.DictReader(io.StringIO(report.to_summary_csv())))
    assert {(r["parameter"], r["side"]) for r in rows} == {(p, s) for p in STEP_PARAMETERS
                                                             for s in ("all", "left", "right")}
    row = next(r for r in rows if r["parameter"] == "step_length_mm" and r["side"] == "left")
    assert float(row["mean"]) == pytest.approx(left, abs=1e-3 * left)
    assert float(row["symmetry_index_pct"]) == pytest.approx(30.0, abs=0.5)
    data = report.to_dict()["summary"]
    assert data["parameters"]["double_support_pct"]["right"]["n"] >= 2
    assert data["asymmetry_pct"]["step_width_mm"] is not None


def test_contact_distance_is_the_distance_walked_in_25_ms_at_least_20_mm():
    assert contact_distance(1200.0) == pytest.approx(30.0)
    assert contact_distance(600.0) == pytest.approx(20.0)
    assert contact_distance(600.0, GaitConfig(contact_distance_mm=10.0)) == pytest.approx(15.0)


@pytest.mark.parametrize("pattern", ["slow", "parkinsonian", "hemiparetic"])
def test_heel_strikes_of_slow_and_shuffling_gaits_are_not_early(pattern):
    """The walker's slower patterns (0.70-0.83 m/s, heels rolling 15-25 mm after initial contact; ground
    truth frames): heel strikes within half a frame of the true initial contacts as a rule (a fixed 30 mm
    contact distance found the Parkinsonian ones 40 ms, the hemiparetic ones 29 ms early)."""
    trial = make_trial("paper", seconds=20.0, seed=0, walk=getattr(WalkParams, pattern)())
    report = analyze_gait(trial.points_mm, trial.times_s, trial.skeleton.joint_names)
    errors = []
    for c in report.contacts:
        true = np.asarray(trial.truth.heel_strike_s[c.foot])
        e = c.heel_strike_s - true[np.argmin(np.abs(true - c.heel_strike_s))] if len(true) else np.nan
        if abs(e) < 0.25:
            errors.append(e)
    assert len(errors) >= 15, f"{pattern}: {len(errors)} heel strikes matched"
    assert abs(np.median(errors)) <= 0.5 / 30, f"{pattern}: signed median {1000 * np.median(errors):+.0f} ms"
