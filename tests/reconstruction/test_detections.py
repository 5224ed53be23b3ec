import numpy as np
import pytest
from gaitcap.reconstruction.detections import Detections, validate_keypoints


def _kp(c=2, t=4, j=26):
    kp = np.random.default_rng(0).uniform(0, 500, size=(c, t, j, 3))
    kp[..., 2] = 0.9
    return kp


def test_valid_detections_and_confident_mask():
    kp = _kp()
    kp[1, 2, 5] = np.nan
    kp[0, 0, 0, 2] = 0.2
    d = Detections(kp, ("a", "b"), np.arange(4) / 30, "halpe26")
    assert d.shape == (2, 4, 26) and d.skeleton.name == "halpe26"
    mask = d.confident()
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
def test_bad_fields_are_named(kwargs, message):
    args = {"keypoints": _kp(), "camera_names": ("a", "b"), "times_s": np.arange(4) / 30, "skeleton": "halpe26"}
    args.update(kwargs)
    with pytest.raises(ValueError, match=message):
        Detections(**args)


def test_confidence_out_of_range_and_person_layout():
    kp = _kp()
    kp[0, 0, 0, 2] = 1.5
    with pytest.raises(ValueError, match=r"confidence .* \[0, 1\]"):
        Detections(kp, ("a", "b"), np.arange(4) / 30, "halpe26")
    multi = np.stack([_kp(), _kp()], axis=2)  # (C, T, P, J, 3)
    out, names, times, skel = validate_keypoints(multi, ["a", "b"], np.arange(4), "halpe26", layout="(C, T, P, J, 3)")
    assert out.shape == (2, 4, 2, 26, 3) and names == ("a", "b") and skel.num_joints == 26
    with pytest.raises(ValueError, match=r"\(C, T, P, J, 3\)"):
        validate_keypoints(_kp(), ["a", "b"], np.arange(4), "halpe26", layout="(C, T, P, J, 3)")
