import numpy as np
import pytest
from gaitcap.reconstruction.association.evaluation import score_association


def test_counts_switches_wrong_and_missed():
    ident = np.array([[[0, 1]] * 6])  # (C=1, T=6, P=2)
    tracks = np.array([[[0, 1], [0, 1], [1, 0], [0, 1], [0, -1], [0, 1]]])
    score = score_association(tracks, ident, min_views=1)
    assert score.main_track == (0, 1)
    assert score.identity_switches == 4  # each person: 0->1->0 (two switches)
    assert score.wrong == 2 and score.missed == 1 and score.total == 12
    perfect = score_association(np.where(ident >= 0, ident + 3, -1), ident)
    assert perfect.identity_switches == perfect.wrong == perfect.missed == 0


def test_shapes_must_match():
    with pytest.raises(ValueError, match="differ"):
        score_association(np.zeros((1, 2, 3), int), np.zeros((1, 2, 2), int))


def test_single_stray_detections_do_not_make_a_switch():
    ident = np.zeros((3, 4, 1), int)  # one person, three cameras, four frames
    tracks = np.array([[0, 0, 1, 0], [0, 0, -1, 0], [0, 0, -1, 0]])[..., None]
    score = score_association(tracks, ident)
    assert score.identity_switches == 0 and score.wrong == 1 and score.missed == 2
    assert score_association(tracks, ident, min_views=1).identity_switches == 2
