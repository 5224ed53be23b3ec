"""The worker's computation helpers: chunked triangulation equals the whole-trial one; the dense sampler
reproduces a smooth trajectory; the compilation cache's folder."""

import numpy as np
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.skeletons import get_skeleton
from gaitcap.reconstruction.triangulation import robust_triangulate
from gaitcap.services.processing.pipeline import (
    FRAME_CHUNK,
    compile_cache_dir,
    dense_sampler,
    pad_detections,
    preliminary,
    ring_rig,
)


def test_chunked_preliminary_equals_whole_trial_triangulation():
    rig, sk = ring_rig(4), get_skeleton("coco17")
    t = FRAME_CHUNK + 37
    rng = np.random.default_rng(1)
    pts = rng.uniform(-400, 400, (t, sk.num_joints, 3)) + [0, 0, 900]
    xy = np.stack([c.project(pts.reshape(-1, 3)).reshape(t, sk.num_joints, 2) for c in rig.cameras])
    kp = np.concatenate([xy + rng.normal(0, 1.0, xy.shape), np.full((*xy.shape[:3], 1), 0.9)], axis=-1)
    kp[1, 10:20, 3, 2] = 0.0  # a few missing views
    det = MultiViewKeypoints.of_one_person(kp, rig.names, np.arange(t) / 30, sk)
    whole = robust_triangulate(det, rig).points_mm
    got = preliminary(det, rig)
    assert got.points_mm.shape == (t, sk.num_joints, 3)
    np.testing.assert_allclose(got.points_mm, whole, atol=0.05)
    assert np.nanmedian(np.abs(got.points_mm - pts)) < 10  # 1 px noise at 5 m


def test_padding_adds_empty_frames_only():
    rig, sk = ring_rig(3), get_skeleton("coco17")
    det = MultiViewKeypoints.of_one_person(np.ones((3, 5, sk.num_joints, 3)) * 0.5, rig.names, np.arange(5) / 30, sk)
    padded = pad_detections(det, 8)
    assert padded.shape == (3, 8, 1, sk.num_joints) and np.all(padded.one_person[:, 5:, :, 2] == 0)
    np.testing.assert_allclose(np.diff(padded.times_s), 1 / 30)


def test_dense_sampler_matches_a_smooth_trajectory_and_clips_the_ends():
    times = np.arange(90) / 30.0

    def truth(t):
        t = np.asarray(t)
        return np.stack([300 * np.sin(2 * np.pi * 1.1 * t), 50 * np.cos(2 * np.pi * 2.3 * t), t * 0 + 5], -1)[:, None]

    sampler = dense_sampler(truth, times)
    t = np.linspace(0, times[-1], 777)
    assert np.max(np.abs(sampler(t) - truth(t))) < 0.05
    np.testing.assert_allclose(sampler(np.array([times[-1] + 1e-3])), truth(times[-1:]), atol=1e-6)


def test_the_compilation_cache_is_the_hosts_where_it_sets_one_else_in_the_data_folder(tmp_path, monkeypatch):
    monkeypatch.delenv("JAX_COMPILATION_CACHE_DIR", raising=False)
    assert compile_cache_dir(tmp_path / "data") == tmp_path / "data" / ".jax-cache"
    monkeypatch.setenv("JAX_COMPILATION_CACHE_DIR", str(tmp_path / "shared"))
    assert compile_cache_dir(tmp_path / "data") == tmp_path / "shared"
    monkeypatch.setenv("JAX_COMPILATION_CACHE_DIR", "")
    assert compile_cache_dir(tmp_path / "data") == tmp_path / "data" / ".jax-cache"
