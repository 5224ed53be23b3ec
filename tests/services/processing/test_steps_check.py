"""A walk with one impossible step (the simulator's FootGlitch: the detector puts one right footfall 100 mm
towards the left foot in every camera) through the one processing path: the step is excluded with its
reason, no finding comes from it, and the trial's quality block says so (so the page never says that every
check passed)."""

import numpy as np
import pytest
from gaitcap.acquisition.importers.keypoint_input import KeypointInput
from gaitcap.reconstruction.methods import Robust
from gaitcap.services.processing.steps_check import steps_check
from gaitcap.services.processing.trial import StagePlan, TrialInput, TrialOptions, process_trial
from gaitcap.services.reports.content import rows_of, stage_said
from gaitcap.services.reports.norms import NormTable
from gaitcap.simulator import make_trial
from gaitcap.simulator.glitch import FootGlitch, glitched_span

GLITCH = FootGlitch(foot="right", footfall=2, shift_mm=100.0)


def _preliminary(trial):
    data = TrialInput(KeypointInput(trial.detections, trial.skeleton.name, trial.rig, "simulated"), trial.rig)
    options = TrialOptions(stages=(StagePlan("preliminary", Robust(), label="robust triangulation", chunked=True),),
                           layout_check=False, kinematics=False, checks=())
    return process_trial(data, options, files=None)


@pytest.fixture(scope="module")
def glitched():
    trial = make_trial("paper", seconds=20.0, cameras=10, seed=0, glitch=GLITCH)
    return trial, _preliminary(trial)


def test_the_glitched_step_is_excluded_with_its_reason_and_the_quality_block_says_so(glitched):
    trial, result = glitched
    start, end, _ = glitched_span(GLITCH, trial.truth)
    report = result.stages["preliminary"].report
    glitched_step = next(s for s in report.steps if s.foot == "right" and abs(s.heel_strike_s - start) < 0.1)
    assert glitched_step.step_width_mm < 30 and glitched_step.steady  # the truth is 100 mm
    assert glitched_step.excluded.startswith("step width ") and "robust SD from this patient's" in glitched_step.excluded
    counted = [s for s in report.steps if s.steady and not s.excluded]
    assert all(s.step_width_mm > 80 for s in counted)  # the walker's 100 mm steps, none impossible left
    check = result.quality.checks["steps"]
    assert check["stage"] == "preliminary" and glitched_step.index in [e["index"] for e in check["excluded"]]
    said = [w for w in result.quality.warnings if w.startswith("The preliminary analysis did not count")]
    assert len(said) == 1 and f"right step at {glitched_step.heel_strike_s:.2f} s (step width" in said[0]
    assert result.quality.serious


def test_no_finding_comes_from_the_glitched_step(glitched):
    _, result = glitched
    gait = result.stages["preliminary"].report.to_dict()
    said = stage_said(gait, "preliminary", rows_of(gait["summary"], NormTable((), (), ""), sex="", age=None), {})
    assert not [f for f in said.findings if "Step width" in f]
    assert gait["summary"]["asymmetry_pct"]["step_width_mm"] < 10


def test_the_same_walk_without_the_glitch_counts_that_step():
    trial = make_trial("paper", seconds=20.0, cameras=10, seed=0)
    start, _, _ = glitched_span(GLITCH, trial.truth)
    report = _preliminary(trial).stages["preliminary"].report
    step = next(s for s in report.steps if s.foot == "right" and abs(s.heel_strike_s - start) < 0.1)
    assert step.excluded == "" and step.step_width_mm == pytest.approx(100.0, abs=15.0)
    assert np.isfinite(report.summary.parameters["step_width_mm"]["right"].mean)


def test_a_stage_without_gait_says_nothing_and_missed_contacts_and_dropped_steps_are_warnings():
    from types import SimpleNamespace

    from gaitcap.reconstruction.gait.parameters import LeftOut

    assert steps_check("refined", None)["warnings"] == []
    summary = SimpleNamespace(num_steps=10, num_edge_steps=2, num_excluded_steps=0)
    report = SimpleNamespace(steps=(), summary=summary, left_out=(
        LeftOut("missed contact", "left", 7.37, "pass 0: two left contacts in a row at 6.97 s and 7.37 s"),
        LeftOut("dropped step", "left", 6.97, "pass 0: left step at 6.97 s dropped (step_length_mm 2134 outside 0-1500)")))
    check = steps_check("refined", report)
    assert check["warnings"] == [
        "The refined analysis missed 1 foot contact: pass 0: two left contacts in a row at 6.97 s and 7.37 s",
        "The refined analysis dropped 1 step with a length no walking step has: pass 0: left step at 6.97 s dropped "
        "(step_length_mm 2134 outside 0-1500)"]
    assert check["counted"] == 8 and check["missed_contacts"][0]["time_s"] == 7.37
