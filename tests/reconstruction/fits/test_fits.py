import numpy as np
import pytest
from gaitcap.reconstruction.fits.bspline import BSplineBasis
from gaitcap.reconstruction.fits.common import fill_gaps, fit_problem, reject_spikes
from gaitcap.reconstruction.fits.explicit import ExplicitFit
from gaitcap.reconstruction.fits.implicit import ImplicitFit, PaperMLP
from gaitcap.reconstruction.fits.optim import LBFGS, Adam, WarmupHoldDecay
from gaitcap.reconstruction.metrics import skeleton_loss_np
from gaitcap.reconstruction.triangulation import robust_triangulate


def _setup(scene, **kw):
    rig, det, gt = scene(rigid=True, **kw)
    rob = robust_triangulate(det, rig)
    init = fill_gaps(reject_spikes(rob.points_mm), det.times_s, det.skeleton.joint_names)
    problem = fit_problem(det, rig, rob.camera_weights)
    return det, gt, rob, init, problem


def _mpjpe(p, gt):
    return float(np.nanmean(np.linalg.norm(p - gt, axis=-1)))


def test_explicit_and_implicit_beat_robust_triangulation(scene):
    det, gt, rob, init, problem = _setup(scene, cameras=4, frames=30, noise_px=3.0, outliers=0.03, seed=1)
    base = _mpjpe(rob.points_mm, gt)
    limbs = det.skeleton.limb_indices
    exp = ExplicitFit(solver=LBFGS(iterations=30)).fit(problem, init, det.times_s)
    imp = ImplicitFit(model=BSplineBasis(max_freq_hz=3.0), solver=LBFGS(iterations=20)).fit(problem, init, det.times_s)
    for out in (exp, imp):
        assert out.points_mm.shape == gt.shape and np.isfinite(out.points_mm).all()
        assert _mpjpe(out.points_mm, gt) < 0.8 * base
        assert skeleton_loss_np(out.points_mm, limbs) < 0.5 * skeleton_loss_np(rob.points_mm, limbs)
        assert out.history[-1] < out.history[0]
    # the implicit result is a function of time: sample between frames, refuse outside the trial
    mid = 0.5 * (det.times_s[10] + det.times_s[11])
    between = imp.trajectory(np.array([det.times_s[10], mid, det.times_s[11]]))
    assert np.allclose(between[0], imp.points_mm[10], atol=1e-2)
    assert np.linalg.norm(between[1] - 0.5 * (imp.points_mm[10] + imp.points_mm[11]), axis=-1).max() < 5
    with pytest.raises(ValueError, match="outside the fitted span"):
        imp.trajectory(np.array([det.times_s[-1] + 1.0]))


def test_paper_mlp_trains(scene):
    det, gt, _, init, problem = _setup(scene, cameras=4, frames=30, noise_px=1.0)
    fit = ImplicitFit(model=PaperMLP(widths=(32, 64, 64)), solver=Adam(learning_rate=1e-3, steps=40, chunk=20))
    out = fit.fit(problem, init, det.times_s)
    assert len(out.history) == 40 and out.history[-1] < 0.9 * out.history[0]
    assert out.trajectory(det.times_s[:2]).shape == (2, 26, 3)
    paper = ImplicitFit.paper()
    assert paper.model.widths == (128, 256, 512, 1024, 2048) and paper.solver.steps == 50_000
    assert paper.solver.reg_start == 5000 and paper.solver.clip_norm == 1.0


def test_paper_schedule():
    sched = WarmupHoldDecay().schedule()
    assert float(sched(0)) == pytest.approx(1e-6)
    assert float(sched(1000)) == pytest.approx(1e-4, rel=1e-3)
    assert float(sched(4000)) == pytest.approx(1e-4, rel=1e-3)
    assert float(sched(50_000)) == pytest.approx(1e-6, rel=1e-2)
    assert 1e-6 < float(sched(20_000)) < 1e-4


def test_reject_spikes_and_fill_gaps():
    t = np.arange(40) / 30
    pts = np.stack([np.stack([100 * t, 50 * t, 900 + 0 * t], -1)] * 2, 1)  # (40, 2, 3)
    bad = pts.copy()
    bad[7, 0] += [0, 0, 1500]  # a wild triangulation
    bad[20, 1] = np.nan
    clean = reject_spikes(bad)
    assert np.isnan(clean[7, 0]).all() and np.isfinite(clean[8, 0]).all()
    filled = fill_gaps(clean, t, ["a", "b"])
    assert np.allclose(filled, pts, atol=1e-6)
    never = pts.copy()
    never[:, 1] = np.nan
    with pytest.raises(ValueError, match=r"\['b'\]"):
        fill_gaps(never, t, ["a", "b"])
