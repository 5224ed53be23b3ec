import numpy as np
from gaitcap.reconstruction.association.config import AssociationConfig
from gaitcap.reconstruction.association.rays import make_rays
from gaitcap.reconstruction.keypoints import MultiViewKeypoints


def test_rays_mask_mirror_and_box_size(scene3):
    cfg = AssociationConfig()
    kp = scene3.multi.keypoints.copy()
    kp[0, 0, 0, :, 2] = 0.1  # not confident: no rays
    kp[1, 0, 0, 5:, 2] = 0.1  # only the face: one association joint (the nose) < min_joints
    multi = MultiViewKeypoints(kp, scene3.multi.camera_names, scene3.multi.times_s, "halpe26")
    jidx = cfg.joint_indices(multi.skeleton)
    rays = make_rays(multi, scene3.rig, jidx, cfg)
    assert rays.dirs.shape == (8, 60, 3, len(jidx), 3) and rays.origins_mm.shape == (8, 3)
    assert not rays.mask[0, 0, 0].any() and np.isnan(rays.pixels_px[0, 0, 0]).all()
    assert rays.mask[1, 0, 0].sum() == 0
    assert rays.mask[2].mean() > 0.9  # the rest: every detected person's body joints
    names = [multi.skeleton.joint_names[j] for j in jidx]
    assert names[rays.flip[names.index("left_knee")]] == "right_knee" and names[rays.flip[0]] == "nose"
    span = np.nanmax(kp[2, 3, 1, :, :2], 0) - np.nanmin(kp[2, 3, 1, :, :2], 0)
    assert np.isclose(rays.scale_px[2, 3, 1], np.hypot(*span))
    assert np.allclose(np.linalg.norm(rays.dirs[2, 3, 1], axis=-1), 1)
