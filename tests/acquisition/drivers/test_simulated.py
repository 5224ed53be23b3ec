import numpy as np
import pytest
from gaitcap.acquisition.drivers.base import CaptureSettings, is_ptp_jump
from gaitcap.acquisition.drivers.simulated import (
    SimulatedCamera,
    SimulatedFaults,
    parse_faults,
    simulated_rig,
)
from gaitcap.acquisition.sync import check_sync
from gaitcap.simulator import make_trial


@pytest.fixture(scope="module")
def trial():
    return make_trial("paper", seconds=5.0, cameras=4, people=1, seed=3, fps=30.0)


def flat_render(trial, camera_index, frame_index, size_px):
    img = np.zeros((size_px[1], size_px[0], 3), np.uint8)
    img[0, 0] = (camera_index, frame_index % 256, 7)
    return img


def test_timestamps_follow_clock_offsets_and_jitter(trial):
    cams = simulated_rig(trial, size_px=(32, 24), realtime=False, render=flat_render, max_frames=40)
    start = 10**18
    for c in cams:
        c.start(start)
    frames = {c.name: list(c.frames()) for c in cams}
    for ci, name in enumerate(trial.rig.names):
        got = np.array([f.timestamp_ns for f in frames[name]])
        want = start + np.arange(40) * 33_333_333 + trial.clock_offsets_ns[ci] + trial.jitter_ns[ci, :40]
        np.testing.assert_array_equal(got, want)
        assert cams[ci].trial_index(frames[name][5].frame_id) == 5
        assert frames[name][5].image.shape == (24, 32, 3) and frames[name][5].image[0, 0, 0] == ci
    report = check_sync({n: [f.timestamp_ns for f in fs] for n, fs in frames.items()}, period_ns=33_333_333)
    assert report.passed, report.problems
    assert report.spread_ms_max < 1.0  # synthetic offsets and jitter are tens of microseconds


def test_dropped_frames_and_a_camera_that_stops(trial):
    faults = parse_faults(["cam02:3,4"], ["cam03:9"])
    cams = simulated_rig(trial, size_px=(16, 12), realtime=False, render=flat_render, faults=faults, max_frames=20)
    for c in cams:
        c.start(0)
    frames = {c.name: [f.frame_id for f in c.frames()] for c in cams}
    assert 3 not in frames["cam02"] and len(frames["cam02"]) == 18
    assert frames["cam03"][-1] == 9
    by_name = {c.name: c.status() for c in cams}
    assert by_name["cam02"].drops == 2 and by_name["cam02"].state == "stopped"
    assert by_name["cam03"].state == "error" and "cam03" in by_name["cam03"].error
    assert by_name["cam01"].frames == 20 and by_name["cam01"].healthy is False  # finished: stopped


def test_realtime_pacing(trial):
    import time

    cam = simulated_rig(trial, size_px=(16, 12), realtime=True, render=flat_render, max_frames=6,
                        cameras=["cam01"])[0]
    t0 = time.time_ns() + 50_000_000
    cam.start(t0)
    got = [(f.timestamp_ns, time.time_ns()) for f in cam.frames()]
    assert all(wall >= ts - 1_000_000 for ts, wall in got)  # never delivered before its timestamp
    assert (got[-1][1] - t0) / 1e9 == pytest.approx(5 / 30, abs=0.08)


def test_bad_arguments_are_named(trial):
    with pytest.raises(ValueError, match="camX"):
        simulated_rig(trial, cameras=["camX"], render=flat_render)
    with pytest.raises(ValueError, match="--drop"):
        parse_faults(["cam01:x"], [])
    with pytest.raises(ValueError, match="camera_index"):
        SimulatedCamera(trial, 9, render=flat_render)
    with pytest.raises(ValueError, match="exposure_us"):
        CaptureSettings(fps=30, exposure_us=40000)
    cam = SimulatedCamera(trial, 0, render=flat_render, faults=SimulatedFaults())
    with pytest.raises(ValueError, match="before start"):
        next(cam.frames())


def test_ptp_jump_rule():
    assert not is_ptp_jump(33_000_000, 33_333_333)
    assert is_ptp_jump(400_000_000, 33_333_333) and is_ptp_jump(-5, 33_333_333)
    assert is_ptp_jump(3_400_000, 33_333_333) is False and is_ptp_jump(3_300_000, 33_333_333)


def test_a_looping_camera_plays_the_walk_again_with_no_pause(trial):
    """The walk starts over at once: frame ids count on, the frame period holds across the end, the
    pictures and ground truth are those of the walk's start again."""
    cam = simulated_rig(trial, size_px=(16, 12), realtime=False, render=flat_render, cameras=["cam02"], loop=True)[0]
    n = cam.walk_frames()
    assert n == 150  # 5 s at 30 fps
    cam.start(10**18)
    frames = []
    for f in cam.frames():
        frames.append(f)
        if len(frames) == 2 * n + 10:
            break
    ids = [f.frame_id for f in frames]
    assert ids == list(range(2 * n + 10)) and cam.status().state == "running"
    gaps = np.diff([f.timestamp_ns for f in frames])
    assert gaps.max() < 1.5 * cam.settings.period_ns, "a pause where the walk starts over"
    assert [cam.trial_index(i) for i in (n - 1, n, n + 1, 2 * n + 3)] == [n - 1, 0, 1, 3]
    assert frames[n].image[0, 0, 1] == 0 and frames[n + 7].image[0, 0, 1] == 7
    assert not any(f.ptp_jump for f in frames)
    cam.stop()


def test_a_looping_camera_with_max_frames_stops_there(trial):
    cam = simulated_rig(trial, size_px=(16, 12), realtime=False, render=flat_render, cameras=["cam01"], loop=True,
                        max_frames=200)[0]
    cam.start(0)
    assert [f.frame_id for f in cam.frames()] == list(range(200))
    assert cam.status().state == "stopped"
