"""The recorder's per-camera tally: gaps, a camera that stopped early, and a counter that started again."""

from gaitcap.services.nodes.recorder import CameraTally


def _tally(ids):
    t = CameraTally()
    t.frame_ids.extend(ids)
    t.frames = len(ids)
    return t


def test_gaps_and_a_camera_that_stopped_early():
    s = _tally([10, 11, 12, 15, 16, 11]).summary(last_frame_id_all=20)
    assert s["gaps"] == [[13, 14], [17, 20]] and s["missing_frames"] == 6
    assert s["stopped_early"] and s["restarts"] == 0 and s["duplicates"] == 1


def test_a_restarted_counter_is_counted_not_read_as_hundreds_of_missing_frames():
    ids = list(range(700, 800)) + list(range(0, 50)) + [52, 53]
    s = _tally(ids).summary(last_frame_id_all=799)
    assert s["restarts"] == 1 and s["gaps"] == [[50, 51]] and s["missing_frames"] == 2
    assert not s["stopped_early"] and s["duplicates"] == 0


def test_frames_reordered_on_the_bus_are_not_a_restart():
    s = _tally([100, 101, 103, 102, 104, 60]).summary(last_frame_id_all=104)
    assert s["restarts"] == 0 and s["duplicates"] == 0 and s["gaps"] == [[61, 99]]
