import numpy as np
import pytest
from gaitcap.reconstruction.association.crossview import FramePeople
from gaitcap.reconstruction.association.tracking import TrackingConfig, link_tracks


def _people(roots):
    """FramePeople from roots (T, K, 3) (NaN = absent); one camera, one slot per person."""
    roots = np.asarray(roots, float)
    t_, k_, _ = roots.shape
    seen = np.isfinite(roots[..., 0])
    labels = np.where(seen, np.arange(k_), -1)[None]  # (1, T, K): slot k holds person k
    return FramePeople(labels=labels, points_mm=roots[:, :, None, :], root_mm=roots,
                       views=seen.astype(int) * 4, joint_indices=(0,))


def _walk(t_, x0, vx, y=0.0, fps=30.0):
    t = np.arange(t_) / fps
    return np.stack([x0 + vx * t, np.full(t_, y), np.full(t_, 900.0)], -1)


def test_two_people_side_by_side_keep_their_ids_through_missed_frames():
    times = np.arange(90) / 30
    a, b = _walk(90, -2000, 1200), _walk(90, -2100, 1200, y=600)
    roots = np.stack([a, b], 1)
    roots[30:40, 0] = np.nan  # patient missed for a third of a second
    order = np.random.default_rng(0).random((90, 2)).argsort(1)  # arbitrary per-frame order
    roots = np.take_along_axis(roots, order[..., None], 1)
    tracks = link_tracks(_people(roots), times, ("cam",), TrackingConfig())
    assert tracks.num_tracks == 2
    truth = np.take_along_axis(np.stack([np.zeros(90), np.ones(90)], 1), order, 1)
    got = tracks.detection_track[0]
    for person in (0, 1):
        ids = got[(truth == person) & (got >= 0)]
        assert len(set(ids.tolist())) == 1
    assert tracks.seen().sum() == 2 * 90 - 10


def test_person_entering_and_leaving_gets_its_own_track_and_a_long_absence_ends_a_track():
    times = np.arange(120) / 30
    a = _walk(120, -2000, 1000)
    b = np.full((120, 3), np.nan)
    b[60:100] = _walk(40, 1500, 0, y=-1500)
    a[40:100] = np.nan  # gone for 2 s > max_gap_s: comes back as a new track
    tracks = link_tracks(_people(np.stack([a, b], 1)), times, ("cam",), TrackingConfig(max_gap_s=1.0))
    first = {int(tracks.detection_track[0, t, 0]) for t in range(40)}
    later = {int(tracks.detection_track[0, t, 0]) for t in range(100, 120)}
    stand = {int(tracks.detection_track[0, t, 1]) for t in range(60, 100)}
    assert len(first) == len(later) == len(stand) == 1 and len(first | later | stand) == 3
    assert tracks.num_tracks == 3
    assert np.isnan(tracks.root_mm[:, 40:60]).all()


def test_flicker_shorter_than_min_track_is_dropped():
    roots = np.full((30, 1, 3), np.nan)
    roots[10:12, 0] = [0, 0, 900]
    tracks = link_tracks(_people(roots), np.arange(30) / 30, ("cam",), TrackingConfig(min_track_s=0.2))
    assert tracks.num_tracks == 0 and np.all(tracks.detection_track == -1)


def test_check_id_and_config_errors():
    tracks = link_tracks(_people(_walk(30, 0, 0)[:, None]), np.arange(30) / 30, ("cam",), TrackingConfig())
    assert tracks.check_id(0) == 0
    with pytest.raises(ValueError, match="track id 5 does not exist"):
        tracks.check_id(5)
    with pytest.raises(ValueError, match="gate_mm"):
        TrackingConfig(gate_mm=-1)


def test_summaries_describe_each_track():
    times = np.arange(60) / 30
    walker, stander = _walk(60, -1000, 1200), _walk(60, 2000, 0, y=-1500)
    stander[:30] = np.nan
    tracks = link_tracks(_people(np.stack([walker, stander], 1)), times, ("cam",), TrackingConfig())
    a, b = tracks.summaries()
    assert (a.track_id, a.frames, b.frames) == (0, 60, 30)
    assert a.first_s == 0 and b.first_s == pytest.approx(1.0) and a.last_s == pytest.approx(59 / 30)
    assert a.path_mm == pytest.approx(1200 * 59 / 30) and b.path_mm == pytest.approx(0)
    assert a.mean_views == 4 and b.mean_position_mm == pytest.approx((2000, -1500, 900))


def test_a_person_seen_by_two_cameras_continues_a_track_but_starts_none():
    roots = np.stack([_walk(40, 0, 1000), _walk(40, 2000, 0, y=-1500)], 1)
    people = _people(roots)
    views = people.views.copy()
    views[:, 0] = 2  # the walker: two cameras only, always
    views[20:, 1] = 2  # the stander: well seen at first, then by two cameras only
    people = FramePeople(labels=people.labels, points_mm=people.points_mm, root_mm=people.root_mm,
                         views=views, joint_indices=(0,))
    tracks = link_tracks(people, np.arange(40) / 30, ("cam",), TrackingConfig(min_views_to_start=3))
    assert tracks.num_tracks == 1 and tracks.seen()[0].all()
    assert np.all(tracks.detection_track[0, :, 0] == -1)
