"""One record per camera of the keypoint messages a recording's reader left out."""

import json

import pytest
from gaitcap.reconstruction.ignored_keypoints import STRAY_EXAMPLES, IgnoredKeypoints


def test_of_counts_every_stray_and_names_the_first_few_and_to_dict_is_json():
    ids = tuple(range(100, 100 + STRAY_EXAMPLES + 2))
    ign = IgnoredKeypoints.of(ids, mistimed=2, unreadable={"not JSON": 3, "missing 'people'": 1})
    assert (ign.strays, ign.stray_frame_ids, ign.mistimed, ign.unread) == (len(ids), ids[:STRAY_EXAMPLES], 2, 4)
    assert json.loads(json.dumps(ign.to_dict())) == {"strays": len(ids), "stray_frame_ids": list(ids[:STRAY_EXAMPLES]),
                                                     "mistimed": 2, "unreadable": {"not JSON": 3, "missing 'people'": 1}}


@pytest.mark.parametrize("kwargs,match", [
    ({"strays": 1, "mistimed": 2}, "mistimed 2 must be within 0..strays 1"),
    ({"strays": 1, "stray_frame_ids": (4, 5)}, "2 stray frame ids named for 1 strays"),
    ({"unreadable": {"not JSON": 0}}, "unreadable counts must be >= 1"),
])
def test_an_inconsistent_record_is_refused_saying_what(kwargs, match):
    with pytest.raises(ValueError, match=match):
        IgnoredKeypoints(**kwargs)
