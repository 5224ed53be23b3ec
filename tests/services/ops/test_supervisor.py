"""The supervisor with real child processes: crashed children restart with growing back-off, forever,
and the supervisor says which child waits for a restart (it never gives up silently)."""

import signal
import sys
import time

from gaitcap.services.ops.supervisor import Backoff, ProcessSpec, Supervisor

FAST = Backoff(first_s=0.05, max_s=0.4, stable_s=5.0)


def _poll_until(sup, predicate, timeout_s=20.0):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        sup.poll()
        if predicate():
            return
        time.sleep(0.01)
    raise AssertionError(f"timed out; states: {sup.states()}")


def test_backoff_doubles_up_to_the_cap():
    assert [FAST.delay_s(n) for n in (1, 2, 3, 4, 5)] == [0.05, 0.1, 0.2, 0.4, 0.4]


def test_a_crash_looping_child_is_restarted_again_and_again_with_growing_delays(tmp_path):
    sup = Supervisor(tmp_path / "logs")
    sup.start(ProcessSpec("crasher", (sys.executable, "-c", "import sys; sys.exit(3)"), backoff=FAST))
    restarts_at = []
    try:
        deadline = time.monotonic() + 30
        while len(restarts_at) < 7 and time.monotonic() < deadline:  # more than the old limit of 3
            if sup.poll():
                restarts_at.append(time.monotonic())
            time.sleep(0.005)
        assert len(restarts_at) == 7, sup.states()
        gaps = [b - a for a, b in zip(restarts_at, restarts_at[1:], strict=False)]
        assert gaps[-1] >= 0.35 and gaps[-1] > 2 * gaps[0], gaps  # 0.4 s cap reached from ~0.1 s
        _poll_until(sup, lambda: sup.states()[0].state == "waiting")
        st = sup.states()[0]
        assert st.last_exit_code == 3 and st.crashes_in_a_row >= 7 and st.restart_at is not None
    finally:
        sup.stop(grace_s=2)


def test_a_killed_child_comes_back_and_is_reported_running(tmp_path):
    sup = Supervisor(tmp_path / "logs")
    sup.start(ProcessSpec("sleeper", (sys.executable, "-c", "import time; print('ready', flush=True); "
                                                            "time.sleep(60)"), ready_text="ready", backoff=FAST))
    try:
        sup.wait_ready("sleeper", 20)
        pid = sup.pid("sleeper")
        sup.kill("sleeper", signal.SIGKILL)
        _poll_until(sup, lambda: sup.restarts("sleeper") == 1)
        sup.wait_ready("sleeper", 20)
        st = sup.states()[0]
        assert st.state == "running" and st.pid != pid and st.last_exit_code == -signal.SIGKILL
    finally:
        sup.stop(grace_s=2)
