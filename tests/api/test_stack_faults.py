"""Trial integrity with the whole stack as real processes (simulated cameras, detector, recorder,
worker, API; Zenoh on loopback; SQLite), faults injected by SIGKILL through the supervisor: concurrent
Stops, the recorder killed mid-trial, the camera node killed mid-trial, every camera down at Start, the
recorder crashing again and again. Every recording is kept, every faulted trial ends with its warnings,
and the API reports each fault within 5 s. One stack serves the module (15 fps cameras, no refined fit:
the criteria scale with the rate; the refined fit is not what is tested here)."""

import pytest
from gaitcap.services.bus.session import free_loopback_ports
from gaitcap.services.ops.faults import (
    Drill,
    camera_killed,
    cameras_down_at_start,
    concurrent_stops,
    recorder_killed,
    repeated_crashes,
)
from gaitcap.services.ops.stack import Stack, StackConfig

DETECT_S = 5.0


@pytest.fixture(scope="module")
def drill(tmp_path_factory):
    base = free_loopback_ports(12)[0]
    cfg = StackConfig(data_dir=tmp_path_factory.mktemp("faults") / "clinic", token="fault-test-password-42",
                      port=base, bus_base_port=base + 1, cameras=4, size="160x120", fps=15.0, sim_seconds=240.0,
                      lease_s=4.0, refine=False)
    with Stack(cfg) as stack:
        d = Drill(stack, timeout_s=150)
        try:
            yield d
        finally:
            d.close()


def test_concurrent_stops_end_in_one_processed_trial(drill):
    res = concurrent_stops(drill, n=6)
    assert res.flagged and not res.lost, res  # six 200s, one job, the recording processed


def test_recorder_killed_mid_trial_the_recording_is_recovered_processed_and_flagged(drill):
    res = recorder_killed(drill)
    assert not res.lost and res.recovered and res.flagged, res
    assert res.state == "done_with_warnings" and "recovered" in res.detail
    assert res.detect_s < DETECT_S, res


def test_camera_killed_mid_trial_the_trial_is_flagged(drill):
    res = camera_killed(drill)
    # the camera node is restarted within the trial: its frame ids start again, its frames are placed by time
    assert not res.lost and res.flagged and res.state == "done_with_warnings", res
    assert "restarted during the trial" in res.detail, res
    assert res.detect_s < DETECT_S, res


def test_all_cameras_down_start_is_refused(drill):
    res = cameras_down_at_start(drill)
    assert res.flagged and "no camera is delivering images" in res.detail, res
    assert res.detect_s < DETECT_S, res


def test_repeated_recorder_crashes_are_restarted_and_reported(drill):
    res = repeated_crashes(drill, crashes=4)
    assert res.flagged and not res.lost and res.state in ("done", "done_with_warnings"), res
    assert res.detect_s < DETECT_S, res
