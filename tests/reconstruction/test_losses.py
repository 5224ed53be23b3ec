import jax
import jax.numpy as jnp
import numpy as np
import pytest
from gaitcap.reconstruction.fits.common import fit_problem
from gaitcap.reconstruction.losses import (
    LossConfig,
    huber,
    reprojection_loss,
    skeleton_loss,
    smooth_loss,
    total_loss,
)
from gaitcap.reconstruction.metrics import huber_np, skeleton_loss_np, smooth_loss_np


def test_huber_shape_and_slope_cut():
    d = jnp.array([0.0, 3.0, 5.0, 8.0, 10.0, 20.0])
    plain = np.asarray(huber(d**2, LossConfig()))
    assert plain[:3] == pytest.approx(0.5 * np.array([0, 9, 25]))
    assert plain[3] == pytest.approx(5 * (8 - 2.5))
    cut = np.asarray(huber(d**2, LossConfig(cut_px=10.0)))
    assert cut[:5] == pytest.approx(plain[:5])
    assert cut[5] == pytest.approx(plain[4] + 0.1 * 5 * 10)  # slope 0.5 px^-1 beyond 10 px
    assert np.allclose(plain, huber_np(np.asarray(d), LossConfig()))
    g = jax.grad(lambda x: huber(x**2, LossConfig()).sum())(d)
    assert np.all(np.isfinite(np.asarray(g)))


def test_losses_on_truth_and_against_numpy_metrics(scene):
    rig, det, gt = scene(cameras=4, frames=12, noise_px=0.0, rigid=True)
    problem = fit_problem(det, rig, np.ones(det.one_person.shape[:3]))
    pts = jnp.asarray(np.transpose(gt, (2, 0, 1)), jnp.float32)
    assert float(reprojection_loss(pts, problem, LossConfig())) < 1e-3
    assert float(skeleton_loss(pts, problem.limb_a, problem.limb_b)) < 0.05  # rigid body: constant limbs
    assert float(smooth_loss(pts)) == pytest.approx(smooth_loss_np(gt), rel=1e-4)
    wobbly = gt + np.random.default_rng(0).normal(0, 5, gt.shape)
    wp = jnp.asarray(np.transpose(wobbly, (2, 0, 1)), jnp.float32)
    limbs = det.skeleton.limb_indices
    assert float(skeleton_loss(wp, problem.limb_a, problem.limb_b)) == pytest.approx(
        skeleton_loss_np(wobbly, limbs), rel=1e-3)
    total, parts = total_loss(wp, problem, LossConfig())
    assert float(total) == pytest.approx(float(parts["reproj"]) + 0.1 * (float(parts["smooth"]) + float(parts["skeleton"])), rel=1e-5)
    assert float(parts["reproj"]) > 1.0


def test_zero_weight_observations_are_ignored(scene):
    rig, det, gt = scene(cameras=3, frames=4, noise_px=0.0)
    kp = det.one_person.copy()
    kp[0, :, :, :2] = np.nan  # camera 0 lost: weight 0, NaN-free observations
    w = np.ones(det.one_person.shape[:3])
    from gaitcap.reconstruction.keypoints import MultiViewKeypoints

    problem = fit_problem(MultiViewKeypoints.of_one_person(kp, det.camera_names, det.times_s, det.skeleton), rig, w)
    assert np.isfinite(np.asarray(problem.obs.u_px)).all()
    assert float(np.asarray(problem.obs.weight)[0].sum()) == 0
    pts = jnp.asarray(np.transpose(gt, (2, 0, 1)), jnp.float32)
    assert float(reprojection_loss(pts, problem, LossConfig())) < 1e-3
