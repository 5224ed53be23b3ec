"""The soak (``bench/soak.py``) in short, on the stack as real processes: two trials, a 5 s walk that starts
over several times meanwhile. Every trial done, no recording lost, no process restarted, no camera's frame
count going back, the cameras' pauses short, memory and disk figures for every process and trial."""

import pytest
from gaitcap.services.bus.session import free_loopback_ports
from gaitcap.services.ops.soak import FrameGaps, SoakReport, life_slope, lives, run_soak, slope
from gaitcap.services.ops.stack import Stack, StackConfig


def test_frame_gaps_count_missing_ids_pauses_and_restarts():
    gaps = FrameGaps()
    for frame_id, t in [(0, 0.0), (1, 0.1), (4, 0.2), (5, 1.7), (0, 1.8)]:
        gaps.see("cam01", frame_id, t)
    c = gaps.snapshot()["cam01"]
    assert (c["frames"], c["missing_ids"], c["longest_missing_run"], c["restarted_count"]) == (5, 2, 2, 1)
    assert c["longest_pause_s"] == pytest.approx(1.5)


def test_memory_growth_is_judged_over_each_life_of_a_process_not_through_its_restarts():
    """A process growing 2 MB a trial, restarted halfway (its memory drops back): one line through the drop
    reads 0.5 MB a trial (under a 1 MB target); each life reads 2."""
    values = [100.0 + 2 * k for k in range(20)] + [100.0 + 2 * k for k in range(20)]
    pids = [11] * 20 + [12] * 20
    assert slope(values) == pytest.approx(0.5, abs=0.01)
    assert life_slope(values, pids) == pytest.approx(2.0)
    assert life_slope(values, []) == pytest.approx(slope(values))  # no ids: one life
    assert [len(life) for life in lives(values, pids)] == [20, 20]
    short = [100.0, 102.0, 50.0, 51.0, 52.0, 53.0, 54.0, 55.0]  # a life of 2 samples gives no slope of its own
    assert life_slope(short, [1, 1, 2, 2, 2, 2, 2, 2]) == pytest.approx(1.0)
    report = SoakReport(minutes=1.0, trials=(), cameras={}, rss_mb={}, restarts={}, disk_per_trial_mb=0.0,
                        frame_period_s=0.1, rss_series_mb={"worker-0": [0.0] * 10 + values},
                        rss_pids={"worker-0": [10] * 10 + pids}, warm_up=10)
    assert report.rss_slope_mb_per_trial["worker-0"] == pytest.approx(2.0)
    assert [life["samples"] for life in report.rss_lives["worker-0"]] == [10, 10]  # each after its warm-up


def test_a_restarted_process_warms_up_again_before_its_growth_is_judged():
    """A worker killed at trial 30 and restarted: its new life grows 5 MB a trial over its own first 10
    trials (compiling, loading), then stays flat, as the stack's first life did: flat, not 5 or 1.7."""
    warm = [500.0 + 5 * k for k in range(10)]
    values, pids = warm + [550.0] * 20 + warm + [550.0] * 20, [1] * 30 + [2] * 30
    assert life_slope(values, pids, warm_up=10) == pytest.approx(0.0)
    assert life_slope(values, pids) > 1.0  # without each life's warm-up its early growth reads as a leak
    grows = warm + [550.0 + 2 * k for k in range(20)]  # a life still growing after its warm-up is judged
    assert life_slope(grows + warm + [550.0] * 20, pids, warm_up=10) == pytest.approx(2.0)
    assert life_slope(values[:33], pids[:33], warm_up=10) == pytest.approx(0.0)  # 3 samples: no life of its own


def test_a_short_life_is_judged_with_the_others_not_alone():
    """The 120-minute day's worker: killed at trials 56 and 71, its middle life kept 5 samples after its own
    warm-up, rising 976 -> 998 MB within the worker's ordinary scatter (19-45 MB from trial to trial): alone it
    read +3.9 MB a trial. Pooled with the long flat lives it reads flat; a long leaking life still reads as
    it grows, and short lives that all grow read as growing."""
    flat = [990.0, 1010.0, 985.0, 1005.0] * 10  # 40 samples, no growth, +-10 MB
    short = [976.0, 994.0, 986.0, 989.0, 998.0]
    values, pids = flat + short + flat, [1] * 40 + [2] * 5 + [3] * 40
    assert slope(short) > 3.0 and life_slope(values, pids) < 0.2
    leaks = [990.0 + 2 * k for k in range(40)]
    assert life_slope(leaks + short + flat, pids) == pytest.approx(2.0)  # one long leaking life is not averaged away
    growing = [500.0 + 3 * k for k in range(8)]
    assert life_slope(growing * 3, [1] * 8 + [2] * 8 + [3] * 8) == pytest.approx(3.0)  # short lives only: pooled


def test_a_short_soak_holds(tmp_path):
    base = free_loopback_ports(12)[0]
    cfg = StackConfig(data_dir=tmp_path / "clinic", token="soak-test-password-42", port=base, bus_base_port=base + 1,
                      cameras=4, size="160x120", fps=15.0, sim_seconds=5.0, refine=False)
    with Stack(cfg) as stack:
        report = run_soak(stack, trials=2, every_s=8.0, trial_s=2.0, stall_s=120.0)
    d = report.to_dict()
    assert report.all_done and report.recordings_lost == 0, d["trials"]
    assert not any(report.restarts.values()), report.restarts
    assert sorted(report.cameras) == ["cam01", "cam02", "cam03", "cam04"]
    for name, c in report.cameras.items():
        assert c["restarted_count"] == 0, (name, c)  # the walk started over, the frame count did not
        assert c["frames"] >= 15.0 * 8, (name, c)
        assert c["missing_ids"] <= 0.05 * c["frames"], (name, c)
        assert c["longest_pause_s"] < 2.0, (name, c)
    assert set(report.rss_mb) == {"recorder", "detector", "camera-0", "worker-0", "api"}
    assert all(first > 10 and last > 10 for first, last, _ in report.rss_mb.values()), report.rss_mb
    assert report.disk_per_trial_mb > 0.1 and d["missing_frame_ids"] == report.missing_frame_ids


def test_a_trial_that_cannot_start_ends_the_day_with_its_report(monkeypatch, tmp_path):
    """A Start refused (here: the disk below the API's threshold) ends the day early, and the report of the
    trials before it is still returned, saying where and why it ended (it used to raise and lose the day)."""
    import types

    import gaitcap.services.ops.soak as soak

    calls = []

    def one_trial(stack, ctx, fault, outcome, **_kw):
        calls.append(1)
        if len(calls) == 3:
            raise RuntimeError("start failed (409): Start refused: data disk: 44.8 GB free (below 44.8 GB)")
        return f"T{len(calls)}", {"state": "done"}, 1.0, 4.0, ""

    monkeypatch.setattr(soak, "_one_trial", one_trial)
    monkeypatch.setattr(soak, "_sample_rss", lambda stack, rss, series, pids: series.setdefault("worker-0", []).append(500.0))
    monkeypatch.setattr(soak, "_recording_kept", lambda stack, trial_id: True)
    monkeypatch.setattr(soak, "_orphans", lambda stack: ())
    session = types.SimpleNamespace(declare_subscriber=lambda key, cb: types.SimpleNamespace(undeclare=lambda: None),
                                    close=lambda: None)
    stack = types.SimpleNamespace(bus_session=lambda: session, bus=types.SimpleNamespace(keys=types.SimpleNamespace(
        image=lambda: "gaitcap/x/image/*")), supervisor=types.SimpleNamespace(children={}, restarts=lambda n: 0),
        data_dir=tmp_path, cfg=types.SimpleNamespace(fps=30.0))
    report = soak.run_soak(stack, trials=5, every_s=0.01, trial_s=0.01, warm_up=0)
    assert [t.trial_id for t in report.trials] == ["T1", "T2"] and report.trials_planned == 5
    assert report.ended_early.startswith("trial 3: start failed (409): Start refused: data disk")
    assert report.to_dict()["ended_early"] == report.ended_early
