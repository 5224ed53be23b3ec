import numpy as np
from gaitcap.reconstruction.association.refine import absorb_explained, assign_greedy, nan_median_last


def test_nan_median_last():
    v = np.array([[1.0, np.nan, 3.0, 2.0], [np.nan] * 4, [4.0, 1.0, np.nan, np.nan]])
    np.testing.assert_array_equal(nan_median_last(v), [2.0, np.nan, 2.5])


def test_greedy_assignment_one_detection_per_person_and_gated():
    inf = np.inf
    cost = np.array([[0.05, 0.01], [0.02, 0.03], [inf, inf]])[None, None]  # (C=1, T=1, P=3, K=2)
    labels = assign_greedy(cost)
    np.testing.assert_array_equal(labels[0, 0], [1, 0, -1])


def test_absorb_only_when_both_groups_explain_each_other():
    # one camera per detection slot: N = C * P with P = 1; groups 0 (3 detections) and 1 (2)
    comp = np.array([[0, 0, 0, 1, 1]])
    fits = np.full((5, 1, 1, 2), np.inf)
    fits[:, 0, 0, 0] = 0.05  # group 0's reprojection fits every detection
    one_way = absorb_explained(comp, fits)
    np.testing.assert_array_equal(one_way, comp)  # group 1 does not explain group 0: kept apart
    fits[:, 0, 0, 1] = 0.05
    np.testing.assert_array_equal(absorb_explained(comp, fits), [[0, 0, 0, 0, 0]])
