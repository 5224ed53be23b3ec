import numpy as np
import pytest
from gaitcap.reconstruction.association.multi import MultiPersonDetections


def _kp(c=2, t=3, p=2, j=26):
    return np.full((c, t, p, j, 3), 0.5)


def test_valid_input_and_confident_mask():
    kp = _kp()
    kp[0, 1, 1, 4] = np.nan
    multi = MultiPersonDetections(kp, ("a", "b"), np.arange(3) / 30, "halpe26")
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
        MultiPersonDetections(kp, names, times, "halpe26")


def test_confidence_out_of_range_is_rejected():
    kp = _kp()
    kp[1, 0, 0, 0, 2] = 1.5
    with pytest.raises(ValueError, match="confidence"):
        MultiPersonDetections(kp, ("a", "b"), np.arange(3), "halpe26")
