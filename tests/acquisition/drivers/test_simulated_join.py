"""Simulated cameras started in several processes share one frame count: a camera started after its
synchronised start joins the running rig (frames already due are not delivered) on the walk's grid."""

import time

import numpy as np
import pytest
from gaitcap.acquisition.drivers.simulated import cycle_start_ns, simulated_rig
from gaitcap.simulator import make_trial

PERIOD_NS = 33_333_333


@pytest.fixture(scope="module")
def trial():
    return make_trial("paper", seconds=5.0, cameras=4, people=1, seed=3, fps=30.0)


def _flat(trial, camera_index, frame_index, size_px):
    return np.zeros((size_px[1], size_px[0], 3), np.uint8)


def test_a_camera_started_late_joins_the_running_rig_on_its_frame_count(trial):
    early, late, behind = simulated_rig(trial, size_px=(32, 24), render=_flat, max_frames=75,
                                        cameras=["cam01", "cam02", "cam03"])
    late.join_running = True
    start = time.time_ns() + 100_000_000
    early.start(start)
    first = next(early.frames())
    time.sleep(1.2)  # the second process comes up a second later with the same synchronised start
    before_ns = time.time_ns()
    late.start(start)
    frames = late.frames()
    joined = next(frames)
    after_ns = time.time_ns()
    assert first.frame_id == 0
    # the frame due when it joined, not a burst of past frames (bounds from the measured times: load-proof)
    due_first, due_last = (before_ns - start) // PERIOD_NS, (after_ns - start) // PERIOD_NS + 1
    assert due_first >= 30 and due_first <= joined.frame_id <= due_last, (due_first, joined.frame_id, due_last)
    want = start + joined.frame_id * PERIOD_NS + trial.clock_offsets_ns[1] + trial.jitter_ns[1, joined.frame_id]
    assert joined.timestamp_ns == want
    rest = [f.frame_id for f in frames]
    assert rest == list(range(joined.frame_id + 1, 75)) and late.status().drops == 0
    assert 20 < late.status().fps() < 40  # its rate counts from when it joined, not from the rig's start
    behind.start(start)  # not joining: every frame from the start, the late ones at once
    assert next(behind.frames()).frame_id == 0


def test_cycle_start_is_shared_by_processes_started_at_different_times():
    epoch, cycle = 1_000_000_000_000, 300_000_000_000
    assert cycle_start_ns(epoch_ns=epoch, cycle_ns=cycle, now_ns=epoch - 5) == epoch  # not yet started
    assert cycle_start_ns(epoch_ns=epoch, cycle_ns=cycle, now_ns=epoch + 12_000_000_000) == epoch
    assert cycle_start_ns(epoch_ns=epoch, cycle_ns=cycle, now_ns=epoch + cycle + 1) == epoch + cycle
    assert cycle_start_ns(epoch_ns=epoch, cycle_ns=cycle, now_ns=epoch + 2 * cycle - 1) == epoch + cycle
    with pytest.raises(ValueError, match="cycle_ns"):
        cycle_start_ns(epoch_ns=epoch, cycle_ns=0, now_ns=epoch)
