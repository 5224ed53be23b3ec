import numpy as np
from gaitcap.reconstruction.association.config import AssociationConfig
from gaitcap.reconstruction.association.hypotheses import (
    consensus_positions,
    linked_components,
    pair_hypotheses,
)
from gaitcap.reconstruction.association.rays import make_rays


def _setup(scene):
    cfg = AssociationConfig()
    rays = make_rays(scene.multi, scene.rig, cfg.joint_indices(scene.multi.skeleton), cfg)
    return cfg, rays


def test_same_person_pairs_hold_and_consensus_sits_on_the_person(crossing_scene):
    cfg, rays = _setup(crossing_scene)
    ok, root, gap = pair_hypotheses(rays, cfg)
    ident = crossing_scene.identity
    same = (ident[:, None, :, :, None] == ident[None, :, :, None, :]) & (ident[:, None, :, :, None] >= 0)
    same &= ~np.eye(len(ident), dtype=bool)[:, :, None, None, None]
    both_seen = rays.mask.any(-1)[:, None, :, :, None] & rays.mask.any(-1)[None, :, :, None, :]
    assert ok[same & both_seen].mean() > 0.98
    assert np.array_equal(ok, ok.transpose(1, 0, 2, 4, 3))  # symmetric
    assert np.nanmax(gap) < cfg.ray_gap_mm
    pos = consensus_positions(ok, root, gap, cfg)  # (T, N, 3)
    c_, t_, p_ = ident.shape
    who = ident.transpose(1, 0, 2).reshape(t_, c_ * p_)
    truth = crossing_scene.points_mm[:, :, cfg.joint_indices(crossing_scene.multi.skeleton)].mean(2)
    err = np.linalg.norm(pos - truth[np.maximum(who, 0), np.arange(t_)[:, None]], axis=-1)
    assert np.nanpercentile(err[who >= 0], 95) < 150


def test_components_hardly_mix_people(crossing_scene):
    cfg, rays = _setup(crossing_scene)
    ok, root, gap = pair_hypotheses(rays, cfg)
    comp = linked_components(ok, root, consensus_positions(ok, root, gap, cfg), cfg)
    c_, t_, p_ = crossing_scene.identity.shape
    who = crossing_scene.identity.transpose(1, 0, 2).reshape(t_, c_ * p_)
    stray = total = 0
    for t in range(t_):
        for k in np.unique(comp[t][comp[t] >= 0]):
            ids = who[t][comp[t] == k]
            stray += len(ids) - np.bincount(ids).max()  # the later steps drop or reassign these
            total += len(ids)
    assert total > 0.9 * (who >= 0).sum() and stray < 0.01 * total
