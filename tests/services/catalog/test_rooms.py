"""Rooms sharing one catalog (SQLite and PostgreSQL): each registers once and keeps its recording slot, two
rooms record at once while each still records one trial at a time, trials list by room, each room's rig
state is kept with when it was seen."""

import threading

import pytest
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import rooms


@pytest.fixture
def db(catalog_url):
    c = cat.open_catalog(catalog_url)
    yield c
    c.close()


def _start(db, room, subject="P001"):
    return cat.start_trial(db, subject_id=subject, session="v1", room=room, recording_path_for=lambda t: f"/d/{t}.mcap")


def test_rooms_record_at_once_and_each_one_trial_at_a_time(db):
    with pytest.raises(rooms.RoomNotFound, match="gait2"):
        _start(db, "gait2")
    first = rooms.register_room(db, "gait2", host="host-b")
    assert (first.slot, first.host, first.recording) == (2, "host-b", None)
    again = rooms.register_room(db, "gait2", host="host-c")  # a restart, maybe on another host: same slot
    assert (again.slot, again.host, again.registered_at) == (2, "host-c", first.registered_at)
    here, there = _start(db, ""), _start(db, "gait2", "P002")
    assert (here.room, there.room) == ("", "gait2")
    with pytest.raises(cat.RecordingBusy, match=f"trial {there.id} is already recording in room gait2"):
        _start(db, "gait2", "P003")
    with pytest.raises(cat.RecordingBusy, match=here.id):
        _start(db, "")
    assert cat.current_recording(db, "gait2").id == there.id and cat.current_recording(db).id == here.id
    assert {r.name: r.recording for r in rooms.list_rooms(db)} == {"gait2": there.id}
    cat.set_state(db, there.id, "recorded")
    assert cat.current_recording(db, "gait2") is None and cat.current_recording(db).id == here.id
    assert [t.id for t in cat.list_trials(db, room="gait2")] == [there.id]
    assert [t.id for t in cat.list_trials(db, room="")] == [here.id]
    assert {t.id for t in cat.list_trials(db)} == {here.id, there.id}
    with pytest.raises(ValueError, match="room"):
        cat.list_trials(db, room="../x")


def test_rooms_registering_at_once_get_slots_of_their_own(catalog_url):
    cat.open_catalog(catalog_url).close()
    barrier, got = threading.Barrier(4), []

    def go(name):
        c = cat.open_catalog(catalog_url)
        barrier.wait()
        try:
            got.append(rooms.register_room(c, name).slot)
        finally:
            c.close()

    threads = [threading.Thread(target=go, args=(f"room{i}",)) for i in range(4)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert sorted(got) == [2, 3, 4, 5]


def test_a_room_keeps_its_rig_state_with_when_it_was_seen(db):
    rooms.register_room(db, "gait2")
    seen = rooms.get_room(db, "gait2").seen_at
    rig = {"cameras": [{"name": "cam01", "healthy": True}, {"name": "cam02", "healthy": False}]}
    rooms.report_rig(db, "gait2", rig)
    got = rooms.get_room(db, "gait2")
    assert got.rig == rig and got.seen_at >= seen
    with pytest.raises(rooms.RoomNotFound, match="gait3"):
        rooms.report_rig(db, "gait3", rig)


def test_each_room_has_its_own_active_calibration_and_board_slot(db):
    from gaitcap.services.catalog import calibration_versions as versions
    from gaitcap.services.catalog import calibrations as cals

    rooms.register_room(db, "gait2")
    here = cat.add_calibration(db, toml="[room1 rig]")
    there = cat.add_calibration(db, toml="[room2 rig]", room="gait2")
    assert cat.latest_calibration(db) == (here, "[room1 rig]")
    assert cat.latest_calibration(db, "gait2") == (there, "[room2 rig]")
    refined = versions.add_version(db, toml="[room2 refined]", replaces_id=there, made_by="refine-rig", trials=[],
                                   comparison={})
    assert cat.latest_calibration(db, "gait2")[0] == refined and cat.latest_calibration(db)[0] == here
    recording = _start(db, "")  # the default room records; the board is filmed in gait2 all the same
    board = cals.start_board_recording(db, recording_path_for=lambda c: f"/d/{c}.mcap", room="gait2")
    assert cals.current_board_recording(db, "gait2").id == board.id and cals.current_board_recording(db) is None
    with pytest.raises(cals.CalibrationBusy, match=recording.id):
        cals.start_board_recording(db, recording_path_for=lambda c: f"/d/{c}.mcap")
    assert {c.room for c in cals.list_calibrations(db, room="gait2")} == {"gait2"}
