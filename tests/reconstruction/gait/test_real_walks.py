"""Gait events on real motion capture (annotated walks installed by deploy/bootstrap.sh) seen by the
simulated 30 fps rig, against the annotations and the published baselines."""

import numpy as np
import pytest
from gaitcap.reconstruction.gait import analyze_gait
from gaitcap.reconstruction.gait.baselines import BASELINES
from gaitcap.reconstruction.gait.parameters import cycle_timing
from gaitcap.reconstruction.gait.tracks import FootTracks
from gaitcap.reconstruction.methods import Robust, reconstruct
from gaitcap.simulator.mocap import available_walks, halpe26_points, load_walk, rig_view

pytestmark = pytest.mark.skipif(len(available_walks()) < 2,
                                reason="real gait walks not installed (deploy/bootstrap.sh install_gait_mocap)")
MATCH_S = 0.25


@pytest.fixture(scope="module")
def walks():
    return {name: load_walk(name) for name in ("healthy", "parkinson")}


def _errors(events, walk, kind):
    """(errors s of matched annotations, annotated count) for one event kind, both feet."""
    out, n = [], 0
    for side in ("left", "right"):
        found = np.asarray(events[kind][side], dtype=float)
        found = found[np.isfinite(found)]
        for t in getattr(walk, f"{kind}_s")[side]:
            n += 1
            if len(found) and np.min(np.abs(found - t)) <= MATCH_S:
                out.append(float(found[np.argmin(np.abs(found - t))] - t))
    return np.array(out), n


def _default_events(report):
    return {k: {s: [getattr(c, f"{k}_s") for c in report.contacts if c.foot == s] for s in ("left", "right")}
            for k in ("heel_strike", "toe_off")}


def test_walks_load_in_the_room_frame_and_bad_annotations_are_screened(walks):
    healthy, parkinson = walks["healthy"], walks["parkinson"]
    for w in walks.values():
        heel = w.markers_mm["left_heel"]
        assert heel[:, 2].min() >= 0.0 and heel[:, 2].min() < 60.0  # floor at 0, z up
        assert heel[-1, 0] - heel[0, 0] > 1500.0  # walking along +x
        assert np.mean(w.markers_mm["left_hip"][:, 1] - w.markers_mm["right_hip"][:, 1]) > 0  # left is left
        assert halpe26_points(w).shape == (len(w.times_s), 26, 3)
    assert parkinson.excluded == () and sum(len(v) for v in parkinson.heel_strike_s.values()) == 6
    reasons = " ".join(r for *_, r in healthy.excluded)
    assert "above the floor" in reasons and "after the previous heel_strike" in reasons
    assert sum(len(v) for v in healthy.heel_strike_s.values()) == 5


def test_rig_view_rejects_a_rate_that_does_not_divide(walks):
    with pytest.raises(ValueError, match="fps"):
        rig_view(walks["healthy"], fps=40.0)
    with pytest.raises(ValueError, match="phase"):
        rig_view(walks["healthy"], phase=5)


@pytest.fixture(scope="module")
def reconstructed(walks):
    """Both walks through the rig (phase 2, paper noise), robust triangulation."""
    out = {}
    for name, w in walks.items():
        view = rig_view(w, phase=2, seed=2)
        rec = reconstruct(view.detections, view.rig, method=Robust())
        out[name] = (view, rec.points_mm)
    return out


def test_default_detector_on_reconstructed_real_walks(walks, reconstructed):
    """Every annotated event found, none invented, heel strikes within a frame and a half (median within
    one, signed median within 0.3 of a frame: no systematic bias), toe offs within a frame: and no worse
    than each baseline on the same trajectories."""
    ours = {"heel_strike": [], "toe_off": []}
    baseline = {name: {"heel_strike": [], "toe_off": []} for name in BASELINES}
    for name, w in walks.items():
        view, points = reconstructed[name]
        names = view.detections.skeleton.joint_names
        report = analyze_gait(points, view.times_s, names)
        tracks = FootTracks.from_points(points, view.times_s, names)
        for kind in ours:
            errors, n = _errors(_default_events(report), w, kind)
            assert len(errors) == n, f"{name}: {n - len(errors)} annotated {kind}(s) not found"
            ours[kind] += list(errors)
            for b, fn in BASELINES.items():
                baseline[b][kind] += list(_errors(fn(tracks), w, kind)[0])
        assert len(report.contacts) <= sum(len(v) for v in w.heel_strike_s.values()) + 3
    hs, to = np.abs(ours["heel_strike"]), np.abs(ours["toe_off"])
    assert np.median(hs) <= 1 / 30 and np.percentile(hs, 90) <= 2.6 / 30
    assert abs(np.median(ours["heel_strike"])) <= 0.3 / 30  # not early or late as a rule (measured -0.22 frame)
    assert np.median(to) <= 1 / 30
    for b, errs in baseline.items():
        assert np.median(hs) <= np.median(np.abs(errs["heel_strike"])) + 0.002, b
        assert np.median(to) <= np.median(np.abs(errs["toe_off"])) + 0.002, b


def test_the_slower_walks_heel_strikes_are_not_early_as_a_rule(walks, reconstructed):
    """The Parkinson walk (0.65 m/s: its heels arrive slower and roll less) on the robust triangulation: heel
    strikes neither early nor late as a rule (signed median within 0.3 of a frame) and within 0.8 of a
    frame (median |e|). A fixed 30 mm contact distance found them early: -14 ms signed, 34 ms median |e|."""
    w = walks["parkinson"]
    view, points = reconstructed["parkinson"]
    report = analyze_gait(points, view.times_s, view.detections.skeleton.joint_names)
    errors, n = _errors(_default_events(report), w, "heel_strike")
    assert len(errors) == n
    assert abs(np.median(errors)) <= 0.3 / 30, f"signed median {1000 * np.median(errors):+.0f} ms"
    assert np.median(np.abs(errors)) <= 0.8 / 30, f"median |e| {1000 * np.median(np.abs(errors)):.0f} ms"


def test_short_clip_reports_every_complete_step_with_its_edges(walks, reconstructed):
    """A 4.5 s walkway clip: every step whose two contacts lie in the recording is reported, the first and
    last flagged as edge steps and left out of the summary; stance % close to the force-plate truth."""
    w = walks["parkinson"]
    view, points = reconstructed["parkinson"]
    report = analyze_gait(points, view.times_s, view.detections.skeleton.joint_names)
    other = {"left": "right", "right": "left"}
    complete = [t for side in ("left", "right") for t in w.heel_strike_s[side]
                if (w.heel_strike_s[other[side]] < t).any()]  # the previous contralateral contact is in the clip
    assert len(complete) == 5
    for t in complete:
        assert any(abs(s.heel_strike_s - t) < MATCH_S for s in report.steps), f"no step ending at {t:.2f} s"
    assert len(report.steps) == len(complete)
    assert not report.steps[0].steady and not report.steps[-1].steady
    assert all(s.steady for s in report.steps[1:-1])
    assert report.summary.num_edge_steps == 2
    assert report.summary.parameters["step_time_s"]["all"].n == len(report.steps) - 2
    for s in report.steps:
        truth = cycle_timing(s.foot, s.heel_strike_s, w.heel_strike_s, w.toe_off_s, match_s=MATCH_S)
        if truth is not None and np.isfinite(truth["stance_pct"]) and np.isfinite(s.stance_pct):
            assert abs(s.stance_pct - truth["stance_pct"]) < 5.0
