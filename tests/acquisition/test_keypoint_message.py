"""The keypoint message format, read in one place: what is kept, what is refused and how it is named."""

import json

import numpy as np
import pytest
from gaitcap.acquisition.keypoint_message import KeypointMessageError, parse_keypoint_message


def _msg(people, **over) -> bytes:
    msg = {"camera": "cam01", "frame_id": 12, "timestamp_ns": 10**18, "skeleton": "halpe26", "people": people,
           "detector_ms": 3.5, **over}
    return json.dumps(msg).encode()  # Python's JSON writes NaN and Infinity as such


def test_a_message_is_read_whole_and_nobody_seen_is_zero_people():
    msg = parse_keypoint_message(_msg([[[10.0, 20.0, 0.9], [11.0, 21, 0.0]]]), camera="cam01")
    assert (msg.frame_id, msg.timestamp_ns, msg.skeleton, msg.camera, msg.detector_ms) == (
        12, 10**18, "halpe26", "cam01", 3.5)
    np.testing.assert_array_equal(msg.people, [[[10.0, 20.0, 0.9], [11.0, 21.0, 0.0]]])
    assert parse_keypoint_message(_msg([]), camera="cam01").people.shape == (0, 0, 3)


def test_a_joint_not_seen_may_be_nan_with_confidence_0_where_nan_can_be_read_never_otherwise():
    unseen = _msg([[[float("nan"), float("nan"), 0.0], [1.0, 2.0, 0.5]]])
    people = parse_keypoint_message(unseen, camera="cam03").people
    assert np.isnan(people[0, 0, :2]).all() and people[0, 0, 2] == 0 and people[0, 1].tolist() == [1.0, 2.0, 0.5]
    with pytest.raises(KeypointMessageError, match=r"keypoints of camera cam03\.people\[0\]\[0\]\.x: not a finite"):
        parse_keypoint_message(unseen, camera="cam03", allow_nan=False)  # the bus: JSON without NaN


@pytest.mark.parametrize("people,match,reason", [
    ([[[1.0, float("nan"), 0.4]]], r"people\[0\]\[0\]\.y: NaN with a confidence above 0",
     "'people' y NaN with a confidence above 0 (a joint not seen has confidence 0)"),
    ([[[1.0, 2.0, 0.5], [float("inf"), 2.0, 0.0]]], r"people\[0\]\[1\]\.x: not a finite number",
     "'people' x not a finite number"),
    ([[[1.0, 2.0, 0.5]], [[1.0, 2.0, 1.5]]], r"people\[1\]\[0\]\.confidence: not a number in 0\.\.1 \(got 1\.5\)",
     "'people' confidence not a number in 0..1"),
    ([[[1.0, 2.0, -0.1]]], r"people\[0\]\[0\]\.confidence: not a number in 0\.\.1", None),
    ([[[1.0, 2.0, float("nan")]]], r"people\[0\]\[0\]\.confidence: not a number in 0\.\.1", None),
    ([[[1.0, -2e5, 0.5]]], r"people\[0\]\[0\]\.y: beyond \+-100000 px", "'people' y beyond +-100000 px"),
    # an integer no float holds (JSON's are unbounded): refused, never an OverflowError out of the reader
    ([[[10**400, 2.0, 0.5]]], r"people\[0\]\[0\]\.x: beyond \+-100000 px", "'people' x beyond +-100000 px"),
    ([[[1.0, 2.0, -(10**400)]]], r"people\[0\]\[0\]\.confidence: not a number in 0\.\.1", None),
    ([[[1.0, 2.0, 0.5]] * 3, [[1.0, 2.0, 0.5]] * 2], r"people\[1\]: 2 joints, person 0 has 3", None),
    ([[[1.0, "2", 0.5]]], r"people\[0\]\[0\]\.y: not a number", "'people' y not a number"),
    ([[[1.0, 2.0]]], r"people\[0\]\[0\]: must be \[x px, y px, confidence\]", None),
    ([[[1.0, 2.0, 0.5]]] * 33, r"people: must be a list of at most 32 people", None),
])
def test_a_bad_coordinate_or_confidence_is_refused_naming_the_camera_and_the_field(people, match, reason):
    with pytest.raises(KeypointMessageError, match=r"keypoints of camera cam07\." + match) as err:
        parse_keypoint_message(_msg(people), camera="cam07")
    if reason is not None:
        assert err.value.reason == reason


@pytest.mark.parametrize("data,reason", [
    (b'{"frame_id": ', "not JSON"),
    (b"[1]", "not a JSON object"),
    (json.dumps({"frame_id": 1, "people": []}).encode(), "missing 'timestamp_ns', 'skeleton'"),
    (_msg([], frame_id=1.5), "'frame_id' not an integer"),
    (_msg([], timestamp_ns=True), "'timestamp_ns' not an integer"),
    (_msg([], skeleton=7), "'skeleton' not a name"),
    (_msg([], camera=["cam01"]), "'camera' not a name"),
    (_msg([], detector_ms=-1), "'detector_ms' not a finite number >= 0"),
    (_msg([], detector_ms=10**400), "'detector_ms' not a finite number >= 0"),  # no float holds it
])
def test_a_message_missing_a_field_or_with_one_of_the_wrong_kind_is_refused_saying_which(data, reason):
    with pytest.raises(KeypointMessageError) as err:
        parse_keypoint_message(data, camera="cam02")
    assert err.value.reason == reason and str(err.value).startswith("keypoints of camera cam02")


def test_the_reason_is_the_same_whichever_person_or_joint_is_at_fault():
    reasons = set()
    for p, j in ((0, 0), (1, 5), (2, 25)):
        people = [[[1.0, 2.0, 0.5]] * 26 for _ in range(3)]
        people[p][j] = [1.0, 2.0, 7.0]
        with pytest.raises(KeypointMessageError, match=rf"people\[{p}\]\[{j}\]\.confidence") as err:
            parse_keypoint_message(_msg(people), camera="cam01")
        reasons.add(err.value.reason)
    assert reasons == {"'people' confidence not a number in 0..1"}
