import numpy as np
from gaitcap.reconstruction.calibration import bundle as B
from gaitcap.reconstruction.calibration.geometry import rodrigues_batch, rotation_angle_deg


def _problem(rng, free=(0, 1, 2, 3, 4), cams=3, frames=12):
    xs, ys = np.meshgrid(np.arange(5) * 100.0, np.arange(4) * 100.0)
    obj = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)])
    n = len(obj)
    cam = np.repeat(np.arange(cams), frames * n)
    frame = np.tile(np.repeat(np.arange(frames), n), cams)
    corner = np.tile(np.arange(n), cams * frames)
    k = np.tile(np.array([[1000.0, 0, 640], [0, 1005.0, 400], [0, 0, 1]]), (cams, 1, 1))
    dist = np.tile([-0.1, 0.02, 0.001, -0.001, 0.0], (cams, 1))
    cam_r = rodrigues_batch(np.array([[0, 0, 0], [0, 0.4, 0], [0, -0.4, 0.05]])[:cams])
    cam_t = np.array([[0, 0, 0], [-1200.0, 0, 300], [1200, 50, 300]])[:cams]
    fr = rodrigues_batch(rng.normal(0, 0.25, (frames, 3)))
    ft = np.column_stack([rng.uniform(-400, 100, frames), rng.uniform(-300, 0, frames), rng.uniform(2500, 3500, frames)])
    truth = B.BundleState(k, dist, cam_r, cam_t, fr, ft)
    prob = B.BundleProblem(cam, frame, corner, np.zeros((len(cam), 2)), obj, cams, frames, 0, free)
    uv = B.project_corners(truth, prob, np.arange(len(cam)))
    prob = B.BundleProblem(cam, frame, corner, uv, obj, cams, frames, 0, free)
    return prob, truth


def test_analytic_jacobian_matches_finite_differences():
    rng = np.random.default_rng(0)
    prob, truth = _problem(rng, cams=3, frames=3)
    lay = B._Layout(prob, True)
    rows = np.arange(len(prob.cam))
    x = lay.pack(truth)
    proj = B._project(lay.unpack(x, truth), prob, rows, derivatives=True, rvecs=lay.rvecs(x, truth))
    jac = lay.jacobian(proj, rows, lay.columns(rows)).toarray()
    num = np.zeros_like(jac)
    for i in range(len(x)):
        h = 1e-6 * max(1.0, abs(x[i]))
        e = np.zeros_like(x)
        e[i] = h
        num[:, i] = (B.project_corners(lay.unpack(x + e, truth), prob, rows)
                     - B.project_corners(lay.unpack(x - e, truth), prob, rows)).ravel() / (2 * h)
    assert np.abs(jac - num).max() < 1e-4 * np.abs(num).max()


def _perturbed(rng, truth):
    return B.BundleState(
        truth.matrix_px * [[1.02], [1.02], [1]], truth.dist * 0.5,
        np.concatenate([truth.cam_rotation[:1], truth.cam_rotation[1:] @ rodrigues_batch(rng.normal(0, 0.01, (2, 3)))]),
        truth.cam_tvec_mm + rng.normal(0, 20, (3, 3)) * [[0], [1], [1]], truth.frame_rotation,
        truth.frame_tvec_mm + rng.normal(0, 20, truth.frame_tvec_mm.shape),
    )


def _with_uv(prob, uv):
    return B.BundleProblem(prob.cam, prob.frame, prob.corner, uv, prob.object_points_mm, prob.num_cameras,
                           prob.num_frames, prob.root, prob.free_dist)


def test_bundle_converges_to_truth_without_noise():
    rng = np.random.default_rng(2)
    prob, truth = _problem(rng, free=(0, 1, 2, 3))
    res = B.bundle_adjust(prob, _perturbed(rng, truth), B.BundleConfig(loss="linear"))
    assert res.inlier.all()
    assert np.abs(res.state.cam_tvec_mm - truth.cam_tvec_mm).max() < 1e-3
    assert np.abs(res.state.matrix_px - truth.matrix_px).max() < 1e-3
    assert np.abs(res.residual_px).max() < 1e-5


def test_bundle_rejects_outliers_and_fits_to_the_noise_level():
    rng = np.random.default_rng(3)
    prob, truth = _problem(rng, free=(0,))
    truth = B.BundleState(truth.matrix_px, truth.dist * [1, 0, 0, 0, 0], truth.cam_rotation, truth.cam_tvec_mm,
                          truth.frame_rotation, truth.frame_tvec_mm)
    uv = B.project_corners(truth, prob, np.arange(len(prob.cam))) + rng.normal(0, 0.3, prob.uv_px.shape)
    bad = rng.choice(len(uv), 15, replace=False)
    uv[bad] += rng.choice([-1, 1], (15, 2)) * rng.uniform(8, 30, (15, 2))
    res = B.bundle_adjust(_with_uv(prob, uv), _perturbed(rng, truth), B.BundleConfig())
    assert set(bad) <= set(np.flatnonzero(~res.inlier))
    assert (~res.inlier).sum() < 25
    err = np.linalg.norm(res.residual_px[res.inlier], axis=1)
    assert 0.25 < np.sqrt(np.mean(err**2) / 2) < 0.35  # per-axis RMS ~ the 0.3 px noise
    # a plain least-squares fit is dragged by the outliers
    plain = B.bundle_adjust(_with_uv(prob, uv), _perturbed(rng, truth), B.BundleConfig(loss="linear", max_rounds=1))
    assert np.abs(plain.state.cam_tvec_mm - truth.cam_tvec_mm).max() > np.abs(res.state.cam_tvec_mm - truth.cam_tvec_mm).max()


def test_a_held_principal_point_stays_and_the_rest_still_converges():
    rng = np.random.default_rng(4)
    prob, truth = _problem(rng, free=(0, 1, 2, 3))
    held = np.array([False, True, False])
    prob = B.BundleProblem(prob.cam, prob.frame, prob.corner, prob.uv_px, prob.object_points_mm, prob.num_cameras,
                           prob.num_frames, prob.root, prob.free_dist, held)
    start = _perturbed(rng, truth)
    start.matrix_px[1, :2, 2] = truth.matrix_px[1, :2, 2]  # held at its true place: everything else converges
    res = B.bundle_adjust(prob, start, B.BundleConfig(loss="linear"))
    assert np.array_equal(res.state.matrix_px[1, :2, 2], truth.matrix_px[1, :2, 2])
    assert np.abs(res.state.matrix_px - truth.matrix_px).max() < 1e-3 and np.abs(res.residual_px).max() < 1e-5
    start.matrix_px[1, :2, 2] += (6.0, -4.0)  # held 7.2 px off: it stays there ...
    res = B.bundle_adjust(prob, start, B.BundleConfig(loss="linear"))
    assert np.array_equal(res.state.matrix_px[1, :2, 2], start.matrix_px[1, :2, 2])
    # ... and the camera turns by about as much (atan(7.2 / 1000) = 0.41 deg) to fit nearly as well: the
    # principal point and the rotation are told apart only by the image's edges
    turn = rotation_angle_deg(res.state.cam_rotation[1], truth.cam_rotation[1])
    assert 0.3 < turn < 0.5 and np.abs(res.residual_px).max() < 0.1, (turn, np.abs(res.residual_px).max())


def test_a_shared_focal_prior_pulls_identical_cameras_together():
    """Three cameras whose true focal lengths lie 2 % apart, told to be one model (a focal prior group):
    the prior's cost is the squared standardised spread of fx and fy, and with a tight prior (0.1 %) the
    adjusted focal lengths end much closer together than without it (the corners' own 2 %)."""
    from dataclasses import replace

    rng = np.random.default_rng(3)
    prob, truth = _problem(rng, free=(0,), cams=3, frames=8)
    scale = np.array([1.0, 1.02, 0.98])[:, None, None] ** np.array([[1, 1, 0]])  # fx, fy scaled; cx, cy kept
    truth = replace(truth, matrix_px=truth.matrix_px * scale)
    prob = replace(prob, uv_px=B.project_corners(truth, prob, np.arange(len(prob.cam))))
    grouped = replace(prob, focal_group=np.array([0, 0, 0]), focal_prior_rel=0.001)
    lay = B._Layout(grouped, True)
    x = lay.pack(truth)
    fx, fy = truth.matrix_px[:, 0, 0], truth.matrix_px[:, 1, 1]
    expected = sum(np.sum(((f - f.mean()) / (0.001 * f.mean())) ** 2) for f in (fx, fy))
    assert np.isclose(x @ (lay.prior(truth) @ x), expected)
    assert B._Layout(prob, True).prior(truth).nnz == 0  # no group, no prior
    config = B.BundleConfig(max_rounds=1)
    free = B.bundle_adjust(prob, truth, config).state.matrix_px[:, 0, 0]
    tied = B.bundle_adjust(grouped, truth, config).state.matrix_px[:, 0, 0]
    assert np.ptp(free) > 0.035 * fx.mean() and np.ptp(tied) < 0.2 * np.ptp(free), (tied, free)
