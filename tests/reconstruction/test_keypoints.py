"""The one multi-view keypoints type: its checks, its defaults and the patient of it."""

import numpy as np
import pytest
from gaitcap.reconstruction.keypoints import COMPLETED, LIVE, MISSING, MultiViewKeypoints, validate_keypoints


def _kp(c=2, t=3, p=2, j=26):
    return np.full((c, t, p, j, 3), 0.5)


def test_valid_input_and_confident_mask():
    kp = _kp()
    kp[0, 1, 1, 4] = np.nan
    multi = MultiViewKeypoints(kp, ("a", "b"), np.arange(3) / 30, "halpe26")
    assert multi.shape == (2, 3, 2, 26)
    assert multi.confident(0.3).sum() == kp[..., 0].size - 1


@pytest.mark.parametrize(
    ("kp", "names", "times", "message"),
    [
        (np.zeros((2, 3, 26, 3)), ("a", "b"), np.arange(3), "expected shape"),
        (_kp(), ("a",), np.arange(3), "camera_names"),
        (_kp(), ("a", "a"), np.arange(3), "duplicates"),
        (_kp(j=17), ("a", "b"), np.arange(3), "17 joints"),
        (_kp(), ("a", "b"), np.arange(4), "times_s"),
        (_kp(), ("a", "b"), np.array([0, 2, 1]), "increasing"),
    ],
)
def test_bad_input_is_named(kp, names, times, message):
    with pytest.raises(ValueError, match=message):
        MultiViewKeypoints(kp, names, times, "halpe26")


def test_confidence_out_of_range_is_rejected():
    kp = _kp()
    kp[1, 0, 0, 0, 2] = 1.5
    with pytest.raises(ValueError, match="confidence"):
        MultiViewKeypoints(kp, ("a", "b"), np.arange(3), "halpe26")


def test_recording_facts_default_to_a_file_of_frames_and_are_checked():
    kp = MultiViewKeypoints(_kp(), ("a", "b"), np.arange(3) / 30, "halpe26")
    assert kp.skeleton.name == "halpe26" and kp.frame_ids.tolist() == [0, 1, 2]
    assert kp.timestamps_ns.tolist() == [[0, 33_333_333, 66_666_667]] * 2
    assert (kp.provenance == LIVE).all() and kp.provenance.dtype == np.uint8
    assert kp.fps_hz == pytest.approx(30, rel=1e-9)
    stamps = np.array([[0, -1, 20], [0, 10, 20]])
    rec = MultiViewKeypoints(_kp(), ("a", "b"), np.arange(3) / 100, "halpe26", frame_ids=np.arange(7, 10),
                             timestamps_ns=stamps)
    assert rec.frame_ids.tolist() == [7, 8, 9] and rec.provenance.tolist() == [[LIVE, MISSING, LIVE], [LIVE] * 3]
    done = MultiViewKeypoints(_kp(), ("a", "b"), np.arange(3), "halpe26", timestamps_ns=stamps,
                              provenance=[[LIVE, COMPLETED, LIVE], [LIVE] * 3])
    assert done.provenance[0, 1] == COMPLETED


@pytest.mark.parametrize(("facts", "message"), [
    ({"frame_ids": np.arange(4)}, "frame_ids: expected 3 integer ids"),
    ({"frame_ids": np.arange(3) / 2}, "frame_ids: expected 3 integer ids"),
    ({"timestamps_ns": np.zeros((3, 3), np.int64)}, r"timestamps_ns: expected \(2, 3\)"),
    ({"provenance": np.zeros((2, 2), np.uint8)}, r"provenance: expected \(2, 3\)"),
    ({"provenance": np.full((2, 3), 7)}, r"provenance: .* with \[7\]"),
])
def test_bad_recording_facts_are_named(facts, message):
    with pytest.raises(ValueError, match=message):
        MultiViewKeypoints(_kp(), ("a", "b"), np.arange(3), "halpe26", **facts)


def test_the_patient_is_the_first_person_or_nobody():
    kp = _kp()
    kp[:, :, 1, :, 0] = 7.0
    det = MultiViewKeypoints(kp, ("a", "b"), np.arange(3), "halpe26").patient()
    assert det.shape == (2, 3, 1, 26) and (det.one_person[..., 0] == 0.5).all()
    nobody = MultiViewKeypoints(np.zeros((2, 3, 0, 26, 3)), ("a", "b"), np.arange(3), "halpe26").patient()
    assert nobody.shape == (2, 3, 1, 26) and np.isnan(nobody.one_person[..., 0]).all()
    assert (nobody.keypoints[..., 2] == 0).all()


def _one(c=2, t=4, j=26):
    kp = np.random.default_rng(0).uniform(0, 500, size=(c, t, j, 3))
    kp[..., 2] = 0.9
    return kp


def test_one_person_and_confident_mask():
    kp = _one()
    kp[1, 2, 5] = np.nan
    kp[0, 0, 0, 2] = 0.2
    d = MultiViewKeypoints.of_one_person(kp, ("a", "b"), np.arange(4) / 30, "halpe26")
    assert d.shape == (2, 4, 1, 26) and d.skeleton.name == "halpe26"
    mask = d.confident()[:, :, 0]
    assert not mask[1, 2, 5] and not mask[0, 0, 0] and mask.sum() == 2 * 4 * 26 - 2


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"keypoints": np.zeros((2, 4, 26))}, r"keypoints: expected shape \(C, T, J, 3\)"),
        ({"camera_names": ("a",)}, "camera_names: 1 names for 2 cameras"),
        ({"camera_names": ("a", "a")}, "camera_names: duplicates"),
        ({"skeleton": "coco17"}, "26 joints but skeleton coco17 has 17"),
        ({"times_s": np.arange(3)}, "times_s: expected 4 times"),
        ({"times_s": np.array([0, 1, 1, 2.0])}, "strictly increasing"),
    ],
)
def test_bad_one_person_fields_are_named(kwargs, message):
    args = {"keypoints": _one(), "camera_names": ("a", "b"), "times_s": np.arange(4) / 30, "skeleton": "halpe26"}
    args.update(kwargs)
    with pytest.raises(ValueError, match=message):
        MultiViewKeypoints.of_one_person(**args)


def test_confidence_out_of_range_and_person_layout():
    kp = _one()
    kp[0, 0, 0, 2] = 1.5
    with pytest.raises(ValueError, match=r"confidence .* \[0, 1\]"):
        MultiViewKeypoints.of_one_person(kp, ("a", "b"), np.arange(4) / 30, "halpe26")
    with pytest.raises(ValueError, match=r"keypoints: reconstruction takes one person \(P == 1\), got P = 2"):
        _ = MultiViewKeypoints(np.stack([_one(), _one()], axis=2), ("a", "b"), np.arange(4), "halpe26").one_person
    multi = np.stack([_one(), _one()], axis=2)  # (C, T, P, J, 3)
    out, names, times, skel = validate_keypoints(multi, ["a", "b"], np.arange(4), "halpe26", layout="(C, T, P, J, 3)")
    assert out.shape == (2, 4, 2, 26, 3) and names == ("a", "b") and skel.num_joints == 26
    with pytest.raises(ValueError, match=r"\(C, T, P, J, 3\)"):
        validate_keypoints(_one(), ["a", "b"], np.arange(4), "halpe26", layout="(C, T, P, J, 3)")


def test_frames_keep_their_frame_facts():
    """A subset of frames keeps each frame's id, camera timestamps and provenance (so a chunk or the rig
    check's frames still say where each came from); any number of people."""
    kp = np.random.default_rng(0).uniform(0, 1, (2, 6, 3, 26, 3))
    stamps = np.arange(12).reshape(2, 6) * 10
    stamps[1, 2] = -1
    prov = np.full((2, 6), LIVE, dtype=np.uint8)
    prov[0, 4], prov[1, 2] = COMPLETED, MISSING
    multi = MultiViewKeypoints(kp, ("a", "b"), np.arange(6) / 30, "halpe26", frame_ids=np.arange(6) + 100,
                               timestamps_ns=stamps, provenance=prov, restarts={"a": 1})
    part = multi.frames(np.array([1, 2, 4]))
    assert part.shape == (2, 3, 3, 26)
    np.testing.assert_array_equal(part.keypoints, kp[:, [1, 2, 4]])
    np.testing.assert_array_equal(part.frame_ids, [101, 102, 104])
    np.testing.assert_array_equal(part.timestamps_ns, stamps[:, [1, 2, 4]])
    np.testing.assert_array_equal(part.provenance, prov[:, [1, 2, 4]])
    assert part.restarts == {"a": 1} and part.skeleton is multi.skeleton
    np.testing.assert_allclose(multi.frames(slice(3, None)).times_s, np.arange(3, 6) / 30)
