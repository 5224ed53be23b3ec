import numpy as np
import pytest
from gaitcap.reconstruction.fits.implicit import FourierBasis, ImplicitFit
from gaitcap.reconstruction.fits.optim import LBFGS, Adam
from gaitcap.reconstruction.methods import DLT, METHODS, Explicit, Implicit, Robust, reconstruct


def test_registry_and_paper_configs():
    assert set(METHODS) == {"dlt", "robust", "explicit", "implicit"}
    assert Implicit.paper(steps=10).fit.solver.steps == 10 and not Implicit.paper().use_confidence
    assert Explicit.paper().fit.solver.learning_rate == 0.1
    with pytest.raises(ValueError, match="method"):
        reconstruct(None, None, method="robust")


def test_all_methods_end_to_end(scene):
    rig, det, gt = scene(cameras=4, frames=30, noise_px=2.0, outliers=0.02, rigid=True)
    fast_imp = Implicit(fit=ImplicitFit(model=FourierBasis(max_freq_hz=3.0), solver=LBFGS(iterations=20)))
    seen = []
    results = {}
    for m in (DLT(), Robust(), fast_imp):
        rec = reconstruct(det, rig, method=m, truth_mm=gt, progress=lambda d, t: seen.append((d, t)))
        results[rec.method] = rec
        assert rec.points_mm.shape == gt.shape and rec.camera_weights.shape == det.one_person.shape[:3]
        assert 0 < rec.metrics["GC_20"] <= 1 and rec.metrics["nan_fraction"] < 0.01
    assert seen and seen[-1][0] == seen[-1][1]
    imp = results["implicit"]
    assert results["robust"].metrics["MPJPE"] < 0.5 * results["dlt"].metrics["MPJPE"]
    assert imp.metrics["MPJPE"] < results["robust"].metrics["MPJPE"] < 10
    assert imp.losses["steps"] > 0 and set(imp.losses) >= {"reproj", "smooth", "skeleton"}
    # sampling: implicit evaluates its function, discrete methods interpolate
    t = np.array([0.5 * (det.times_s[3] + det.times_s[4])])
    assert imp.sample(t).shape == (1, 26, 3)
    rob = results["robust"]
    assert np.allclose(rob.sample(t)[0], 0.5 * (rob.points_mm[3] + rob.points_mm[4]))
    with pytest.raises(ValueError, match="outside"):
        rob.sample([det.times_s[-1] + 1])


def test_fit_refuses_a_joint_never_seen(scene):
    rig, det, _ = scene(cameras=4, frames=30, noise_px=1.0)
    kp = det.one_person.copy()
    kp[:, :, det.skeleton.index("left_heel"), 2] = 0.2
    from gaitcap.reconstruction.keypoints import MultiViewKeypoints

    bad = MultiViewKeypoints.of_one_person(kp, det.camera_names, det.times_s, det.skeleton)
    with pytest.raises(ValueError, match="left_heel"):
        reconstruct(bad, rig, method=Implicit())
    rec = reconstruct(bad, rig, method=Robust())  # triangulation: NaN for that joint, no error
    assert np.isnan(rec.points_mm[:, det.skeleton.index("left_heel")]).all()


def test_implicit_puts_the_feet_on_their_own_grid_by_name(scene):
    """BSplineBasis.fast_max_freq_hz reaches the fit through the method: the skeleton's foot joints (by
    name) get the denser grid, the others keep the body's."""
    from gaitcap.reconstruction.fits.bspline import FOOT_JOINTS, BSplineBasis

    rig, det, gt = scene(cameras=4, frames=30, noise_px=1.0, rigid=True)
    model = BSplineBasis(max_freq_hz=3.0, fast_max_freq_hz=6.0, fast_joints=FOOT_JOINTS)
    fit = ImplicitFit(model=model, solver=Adam(learning_rate=1e-4, steps=2, chunk=2))  # the start, barely moved
    rec = reconstruct(det, rig, method=Implicit(fit=fit), truth_mm=gt)
    names = det.skeleton.joint_names
    grids = {g.max_freq_hz: {names[j] for j in g.joints} for g in rec.trajectory.grids}
    assert grids[6.0] == set(FOOT_JOINTS) & set(names) and grids[3.0] == set(names) - grids[6.0]
    assert rec.metrics["MPJPE"] < 10 and rec.sample(det.times_s[:2]).shape == (2, 26, 3)
