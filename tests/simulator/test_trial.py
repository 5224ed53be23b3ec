import cv2
import numpy as np
import pytest
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.simulator import PRESETS, WalkParams, make_trial
from gaitcap.simulator.room import build_rig, visible


def _dlt(rig, keypoints, min_conf=0.5):
    """Tiny confidence-weighted DLT on undistorted pixels: keypoints (C, T, J, 3) -> (T, J, 3) mm."""
    c, t, j, _ = keypoints.shape
    rows, n_views = [], 0
    for ci, cam in enumerate(rig):
        kp = keypoints[ci].reshape(-1, 3)
        und = cv2.undistortPoints(np.nan_to_num(kp[:, None, :2]), cam.matrix_px, cam.dist).reshape(-1, 2)
        use = np.isfinite(kp[:, 0]) & (np.nan_to_num(kp[:, 2]) > min_conf)
        w = np.where(use, kp[:, 2], 0.0)
        p = cam.extrinsics
        rows += [w[:, None] * (und[:, :1] * p[2] - p[0]), w[:, None] * (und[:, 1:] * p[2] - p[1])]
        n_views = n_views + use
    _, _, vt = np.linalg.svd(np.stack(rows, axis=1))
    x = vt[:, -1]
    pts = x[:, :3] / x[:, 3:4]
    pts[n_views < 2] = np.nan
    return pts.reshape(t, j, 3)


def test_api_shapes(paper_trial):
    tr = paper_trial
    t = tr.times_s.shape[0]
    assert t == 360 and np.allclose(np.diff(tr.times_s), 1 / 30)
    assert isinstance(tr.rig, Rig) and tr.rig.names == [f"cam{i:02d}" for i in range(1, 11)]
    assert tr.skeleton.name == "halpe26"
    assert tr.points_mm.shape == (t, 26, 3)
    assert isinstance(tr.detections, MultiViewKeypoints) and tr.detections.one_person.shape == (10, t, 26, 3)
    assert tr.clock_offsets_ns.shape == (10,) and tr.jitter_ns.shape == (10, t)
    assert np.abs(tr.clock_offsets_ns[:, None] + tr.jitter_ns).max() < 100_000
    assert tr.multi is None
    assert set(tr.truth.heel_strike_s) == {"left", "right"}


def test_projection_equals_opencv(paper_trial):
    tr = paper_trial
    pts = tr.points_mm.reshape(-1, 3)
    for cam in tr.rig:
        px, ok = visible(cam, pts)
        ref, _ = cv2.projectPoints(pts[ok], cam.rvec, cam.tvec_mm, cam.matrix_px, cam.dist)
        assert ok.sum() > 100
        assert np.abs(px[ok] - ref[:, 0]).max() <= 1e-6


def test_rig_is_realistic():
    rig = build_rig(10, seed=0)
    fx = np.array([c.matrix_px[0, 0] for c in rig])
    assert set(np.round(fx / 1024).astype(int)) == {1, 2}  # 6 mm and 12 mm lenses
    for cam in rig:
        assert 2000 <= cam.center_mm[2] <= 2500
        assert -0.25 <= cam.dist[0] <= -0.05 and np.all(cam.dist[1:] == 0)
        assert cam.size_px == (1920, 1200)
    with pytest.raises(ValueError, match="cameras"):
        build_rig(1)


def test_every_part_of_the_walk_is_seen_by_several_cameras(clean_trial):
    tr = clean_trial
    for cam_set_seed in (0, 1, 2):
        rig = build_rig(10, seed=cam_set_seed)
        seen = np.stack([visible(cam, tr.points_mm)[1].mean(-1) for cam in rig])  # (C, T) fraction in view
        assert np.all((seen > 0.9).sum(0) >= 2)
        assert np.mean((seen > 0.9).sum(0) >= 3) > 0.9


def test_clean_detections_triangulate_to_ground_truth(clean_trial):
    tr = clean_trial
    pts = _dlt(tr.rig, tr.detections.one_person)
    err = np.linalg.norm(pts - tr.points_mm, axis=-1)
    assert np.isfinite(err).mean() > 0.99
    assert np.nanmedian(err) < 1.0 and np.nanpercentile(err, 99) < 5.0


def test_determinism():
    a = make_trial("paper", seconds=5.0, cameras=4, seed=7)
    b = make_trial("paper", seconds=5.0, cameras=4, seed=7)
    c = make_trial("paper", seconds=5.0, cameras=4, seed=8)
    assert np.array_equal(a.detections.one_person, b.detections.one_person, equal_nan=True)
    assert np.array_equal(a.points_mm, b.points_mm)
    assert np.array_equal(a.jitter_ns, b.jitter_ns)
    assert not np.array_equal(a.detections.one_person, c.detections.one_person, equal_nan=True)


def _error_stats(tr):
    kp = tr.detections.one_person
    proj = np.stack([cam.project(tr.points_mm) for cam in tr.rig])
    err = np.linalg.norm(kp[..., :2] - proj, axis=-1)
    conf = kp[..., 2]
    inview = np.stack([visible(cam, tr.points_mm)[1] for cam in tr.rig]) & np.isfinite(err)
    return err, conf, inview


def test_presets_differ_as_intended():
    assert PRESETS["clean"].outlier_rate == 0 < PRESETS["paper"].outlier_rate < PRESETS["hard"].outlier_rate
    stats = {}
    for name in ("clean", "paper", "hard"):
        err, conf, inview = _error_stats(make_trial(name, seconds=6.0, cameras=6, seed=1))
        stats[name] = (np.median(err[inview]), np.mean(err[inview] > 30))
    assert stats["clean"][0] < 0.5 and stats["clean"][1] == 0
    assert stats["clean"][0] < stats["paper"][0] < stats["hard"][0]
    assert 0 < stats["paper"][1] < stats["hard"][1]


def test_fast_feet_are_detected_worse():
    import dataclasses

    base = dataclasses.replace(PRESETS["paper"], swap_rate=0.0)  # no left/right swaps mixing the heels
    blur = make_trial(base, seconds=8.0, cameras=4, seed=2)
    sharp = make_trial(dataclasses.replace(base, blur_frac=0.0), seconds=8.0, cameras=4, seed=2)
    heels = [blur.skeleton.index("left_heel"), blur.skeleton.index("right_heel")]
    speed = np.linalg.norm(np.gradient(blur.points_mm[:, heels], blur.times_s, axis=0), axis=-1)  # (T, 2)
    e_blur = _error_stats(blur)[0][:, :, heels]
    e_sharp = _error_stats(sharp)[0][:, :, heels]
    ok = np.isfinite(e_blur) & np.isfinite(e_sharp)
    fast = ok & (speed[None] > 2500)
    still = ok & (speed[None] < 1)
    assert fast.sum() > 20 and still.sum() > 20
    assert np.median(e_blur[fast] / np.maximum(e_sharp[fast], 1e-9)) > 1.1
    assert np.allclose(e_blur[still], e_sharp[still])


def test_confidence_correlates_with_error(paper_trial):
    err, conf, inview = _error_stats(paper_trial)
    e, c = err[inview], conf[inview]
    assert np.all((conf >= 0) & (conf <= 1))
    # keypoints with low confidence are worse than confident ones
    assert np.median(e[c < 0.5]) > 2 * np.median(e[c > 0.8])
    # out-of-view joints have near-zero confidence
    out = ~inview & np.isfinite(conf)
    assert np.all(conf[out & np.isfinite(err)] <= 0.15 + 1e-9) or out.sum() == 0


def test_multi_person_identity_is_consistent(multi_trial):
    tr = multi_trial
    m = tr.multi
    c, t, p, j = m.observed.shape
    assert (c, p, j) == (6, 3, 26) and m.points_mm.shape == (3, t, 26, 3)
    assert np.array_equal(m.points_mm[0], tr.points_mm)
    ident = m.identity
    assert ident.shape == (c, t, p) and ident.min() >= -1 and ident.max() <= 2
    # every person at most once per camera and frame; empty slots are NaN with confidence 0
    for who in range(3):
        assert np.all((ident == who).sum(-1) <= 1)
    empty = ident < 0
    kp = m.observed.keypoints
    assert np.all(np.isnan(kp[empty][..., 0])) and np.all(kp[empty][..., 2] == 0)
    # the patient's slots are exactly trial.detections
    assert np.array_equal(m.person(0), tr.detections.one_person, equal_nan=True)
    # slots are shuffled: the patient is not always in slot 0
    assert 0.1 < np.mean(ident[..., 0] == 0) < 0.9
    # each person's detections lie near their own projection
    for who in range(3):
        kp = m.person(who)
        proj = np.stack([cam.project(m.points_mm[who]) for cam in tr.rig])
        err = np.linalg.norm(kp[..., :2] - proj, axis=-1)
        good = np.isfinite(err) & (kp[..., 2] > 0.5)
        assert np.median(err[good]) < 10
    assert m.observed.camera_names == tuple(tr.rig.names) and tr.everyone() is m.observed


def test_occluded_joints_can_be_detected_on_another_person():
    tr = make_trial("hard", seconds=12.0, cameras=10, people=2, seed=0)
    m = tr.multi
    kp = m.person(0)
    own = np.stack([cam.project(m.points_mm[0]) for cam in tr.rig])
    other = np.stack([cam.project(m.points_mm[1]) for cam in tr.rig])
    e_own = np.linalg.norm(kp[..., :2] - own, axis=-1)
    e_other = np.linalg.norm(kp[..., :2] - other, axis=-1)
    on_other = (e_other < 0.5 * e_own) & (e_own > 15) & (kp[..., 2] > 0.4)
    assert on_other.sum() > 20
    single = make_trial("hard", seconds=12.0, cameras=10, people=1, seed=0)
    assert np.array_equal(single.points_mm, tr.points_mm)


def test_other_people_keep_their_distance(multi_trial):
    pel = multi_trial.multi.points_mm[:, :, 19, :2]
    d01 = np.linalg.norm(pel[0] - pel[1], axis=-1)
    d02 = np.linalg.norm(pel[0] - pel[2], axis=-1)
    assert d01.min() > 350 and d02.min() > 500


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(preset="nope"), "unknown preset"),
        (dict(seconds=1.0), "seconds"),
        (dict(cameras=1), "cameras"),
        (dict(people=4), "people"),
        (dict(fps=0.0), "fps"),
        (dict(walk="fast"), "walk"),
    ],
)
def test_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        make_trial(**kwargs)


def test_custom_walk_is_used():
    w = WalkParams(step_length_mm=560.0, step_width_mm=140.0, cadence_spm=100.0)
    tr = make_trial("clean", seconds=14.0, cameras=3, walk=w)
    s = tr.truth.summary()
    assert tr.params is w
    assert s["step_length_mm"] == pytest.approx(560.0, abs=1e-6)
    assert s["step_width_mm"] == pytest.approx(140.0, abs=1e-6)
