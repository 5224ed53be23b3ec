import pytest
from gaitcap.reconstruction.skeletons import GAIT_JOINTS, SKELETONS, get_skeleton


def test_sizes():
    sizes = {k: s.num_joints for k, s in SKELETONS.items()}
    assert sizes == {"coco17": 17, "coco18": 18, "wholebody133": 133, "halpe26": 26, "halpe136": 136, "body25": 25,
                     "body25b": 25, "mediapipe33": 33}


def test_openpose_orders():
    """BODY_25B and COCO-18 in OpenPose's order (as Pose2Sim's skeletons number them)."""
    b = get_skeleton("body25b")
    assert [b.index(n) for n in ("left_eye", "right_shoulder", "left_hip", "right_ankle", "upper_neck", "head_top",
                                 "left_big_toe", "left_heel", "right_heel")] == [1, 6, 11, 16, 17, 18, 19, 21, 24]
    c = get_skeleton("coco18")
    assert [c.index(n) for n in ("neck", "right_shoulder", "left_wrist", "right_hip", "left_ankle", "left_ear")] == [
        1, 2, 7, 8, 13, 17]
    w = get_skeleton("wholebody133")
    assert [w.index(n) for n in ("left_big_toe", "right_heel", "face_0", "left_hand_0", "right_hand_20")] == [
        17, 22, 23, 91, 132]


def test_halpe_limbs_follow_the_paper():
    s = get_skeleton("Halpe-26")
    for side in ("left", "right"):
        for a, b in (("heel", "big_toe"), ("ankle", "knee"), ("knee", "hip"), ("shoulder", "elbow"), ("elbow", "wrist")):
            assert (f"{side}_{a}", f"{side}_{b}") in s.limbs
    assert len(s.openpose_body_indices) == 25 and s.index("head") not in s.openpose_body_indices


def test_gait_map_and_flip():
    s = get_skeleton("halpe26")
    assert set(s.gait_map) == set(GAIT_JOINTS)
    perm = s.flip_permutation
    assert s.joint_names[perm[s.index("left_heel")]] == "right_heel"
    assert sorted(perm) == list(range(26))
    assert not get_skeleton("coco17").has_feet
    mp = get_skeleton("mediapipe33")
    assert mp.has_feet and mp.joint_names[mp.gait_map["left_big_toe"]] == "left_foot_index"


def test_unknown_skeleton():
    with pytest.raises(ValueError, match="known"):
        get_skeleton("nope")
