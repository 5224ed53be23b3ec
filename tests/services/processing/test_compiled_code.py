"""The worker's bound on compiled code: after ``keep_trials`` jobs every compiled executable is dropped (the
count of executables held goes to 0), and a triangulation compiled again gives the same numbers to the last bit."""

import numpy as np
import pytest
from gaitcap.reconstruction.methods import Robust, reconstruct
from gaitcap.services.processing.compiled_code import CompiledCode, CompiledCodeLimit, compiled_executables
from gaitcap.simulator import make_trial


def test_compiled_code_is_dropped_every_keep_trials_jobs_and_the_numbers_stay():
    walk = make_trial("paper", seconds=4.0, cameras=3, people=1, seed=3, fps=30.0)
    method = Robust()  # the preliminary stage's robust triangulation (jitted)
    first = reconstruct(walk.detections, walk.rig, method=method)
    assert compiled_executables() > 0
    code = CompiledCode(CompiledCodeLimit(keep_trials=2))
    assert not code.after_job() and compiled_executables() > 0  # one job: kept
    assert code.after_job() and code.releases == 1 and code.jobs_held == 0
    assert compiled_executables() == 0
    again = reconstruct(walk.detections, walk.rig, method=method)
    np.testing.assert_array_equal(first.points_mm, again.points_mm)


def test_a_bound_below_one_job_is_refused():
    with pytest.raises(ValueError, match="keep_trials"):
        CompiledCodeLimit(keep_trials=0)
