import pytest
from gaitcap.reconstruction.association.config import DEFAULT_ASSOCIATION_JOINTS, AssociationConfig
from gaitcap.reconstruction.skeletons import get_skeleton


def test_default_joints_are_the_body_joints_the_skeleton_has():
    halpe = get_skeleton("halpe26")
    idx = AssociationConfig().joint_indices(halpe)
    assert [halpe.joint_names[i] for i in idx] == list(DEFAULT_ASSOCIATION_JOINTS)
    mp = get_skeleton("mediapipe33")
    assert len(AssociationConfig().joint_indices(mp)) == len(DEFAULT_ASSOCIATION_JOINTS)
    assert AssociationConfig(joints=("left_hip", "right_hip")).joint_indices(halpe) == (11, 12)


@pytest.mark.parametrize("field", ["ray_gap_mm", "consensus_radius_mm", "merge_mm", "reprojection_gate"])
def test_non_positive_distances_are_named(field):
    with pytest.raises(ValueError, match=field):
        AssociationConfig(**{field: 0})


def test_other_bad_settings():
    with pytest.raises(ValueError, match="min_views"):
        AssociationConfig(min_views=1)
    with pytest.raises(ValueError, match="min_inlier_fraction"):
        AssociationConfig(min_inlier_fraction=0)
