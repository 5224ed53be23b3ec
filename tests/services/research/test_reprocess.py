"""Batch reprocessing on a local process pool: a pool worker killed mid-task, results against ground truth,
skip-if-done, resume after the whole run was killed, bad methods and trial filters."""

import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from gaitcap.services.catalog.method_results import list_results
from gaitcap.services.cli import app
from gaitcap.services.research.executors import Inline, LocalPool
from gaitcap.services.research.method_specs import parse_method
from gaitcap.services.research.reprocess import TrialSelection, plan_reprocess, run_plan
from typer.testing import CliRunner

from .reprocess_trials import make_walks, recorded_catalog


@pytest.fixture(scope="module")
def walks():
    return make_walks(2)


def test_local_pool_survives_a_killed_worker_results_match_truth_and_done_pairs_are_skipped(tmp_path, walks):
    db, ids = recorded_catalog(tmp_path, walks)
    plan = plan_reprocess(db, tmp_path, TrialSelection(), [parse_method("robust")],
                          compile_cache=tmp_path / "jax-cache")
    assert len(plan.tasks) == 2 and plan.already_done == 0
    box = {}

    def run() -> None:
        with LocalPool(workers=2).open() as ex:
            box["summary"] = run_plan(plan, ex)

    thread = threading.Thread(target=run)
    thread.start()
    killed = _kill_a_pool_worker_in_its_first_task(db)
    thread.join(240)
    assert killed and not thread.is_alive()
    assert any((tmp_path / "jax-cache").iterdir()), "the workers share a compilation cache"
    summary = box["summary"]
    assert (summary.computed, summary.skipped, summary.failed) == (2, 0, 0)
    results = {r.trial_id: r for r in list_results(db)}
    assert sorted(results) == ids
    for r in results.values():
        assert r.ok and r.skeleton == "halpe26" and r.worker.split("-")[-1] not in (str(os.getpid()), str(killed))
        assert 0.6 < r.metrics["GC_10"] <= 1 and r.metrics["MPJPE"] < 80, r.metrics
        assert r.gait["steps"] >= 4 and r.residuals["reference"] == "ground truth"
        steps = [e for e in r.residuals["parameters"]["step_length_mm"] if e is not None]
        assert len(steps) >= 5 and np.median(np.abs(steps)) < 30, steps
        assert os.path.getsize(r.artifacts["trajectory_npz"]) > 1000
    again = plan_reprocess(db, tmp_path, TrialSelection(), [parse_method("robust:gamma=0.5,sigma_mm=150")])
    assert again.tasks == () and again.already_done == 2  # same config, other spelling: same key
    with Inline().open() as ex:
        assert run_plan(again, ex).skipped == 2
    assert {r.trial_id: r.created_at for r in list_results(db)} == {k: r.created_at for k, r in results.items()}


def _count(db) -> int:
    return len(list_results(db))


def test_a_killed_run_resumes_where_it_stopped(tmp_path, walks):
    db, ids = recorded_catalog(tmp_path, walks)
    argv = [sys.executable, "-c", "from gaitcap.services.cli import main; main()", "reprocess", "--data-dir", str(tmp_path),
            "-m", "robust", "-m", "dlt", "-m", "robust:sigma_mm=100", "--workers", "0"]
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + 240
        while _count(db) == 0 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.2)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(10)
    before = {(r.trial_id, r.params_key): r.created_at for r in list_results(db)}
    assert 1 <= len(before) < 6, "the run should have been killed part-way"
    result = CliRunner().invoke(app, ["reprocess", "--data-dir", str(tmp_path), "-m", "robust", "-m", "dlt",
                                      "-m", "robust:sigma_mm=100", "--workers", "0", "--json"])
    assert result.exit_code == 0, result.output
    counts = [line for line in result.output.splitlines() if line.startswith("{")][-1]
    assert f'"computed": {6 - len(before)}' in counts and f'"skipped": {len(before)}' in counts
    after = list_results(db)
    assert len(after) == 6 and all(r.ok for r in after)
    assert len({(r.trial_id, r.method, r.params_key) for r in after}) == 6
    assert all(r.created_at == before[(r.trial_id, r.params_key)] for r in after if (r.trial_id, r.params_key) in before)


def _pool_children() -> list[int]:
    """Pids of this process's children that run Python (the pool's spawned workers)."""
    out = []
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            stat = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
            cmd = open(f"/proc/{pid}/cmdline", "rb").read()
        except OSError:
            continue
        if int(stat[1]) == os.getpid() and b"spawn_main" in cmd:
            out.append(int(pid))
    return out


def _kill_a_pool_worker_in_its_first_task(db, timeout_s: float = 60.0) -> int | None:
    """SIGKILL one spawned pool worker while no result is stored yet (it is importing or computing)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        kids = _pool_children()
        if kids and _count(db) == 0:
            time.sleep(0.5)
            os.kill(kids[0], signal.SIGKILL)
            return kids[0]
        time.sleep(0.05)
    return None


def test_bad_methods_and_trial_filters(tmp_path, walks):
    db, ids = recorded_catalog(tmp_path, walks)
    runner = CliRunner()
    for args, words in ((["-m", "bogus"], "unknown method 'bogus'"),
                        (["-m", "robust:sigmaa=3"], "unknown parameter 'sigmaa'"),
                        (["-m", "implicit:iterations=2.5"], "parameter iterations: expected an integer"),
                        (["-m", "robust:gamma"], "is not key=value")):
        result = runner.invoke(app, ["reprocess", "--data-dir", str(tmp_path), *args])
        assert result.exit_code == 2 and words in result.output, result.output
    same = plan_reprocess(db, tmp_path, TrialSelection(), [parse_method(m) for m in ("robust", "robust:gamma=0.5", "dlt")])
    assert [s.name for s in same.specs] == ["robust", "dlt"] and len(same.tasks) == 4
    only = plan_reprocess(db, tmp_path, TrialSelection.parse("trial-01"), [parse_method("dlt")])
    assert [t.trial.trial_id for t in only.tasks] == ["trial-01"]
    assert len(plan_reprocess(db, tmp_path, TrialSelection.parse("P1/s1"), [parse_method("dlt")]).tasks) == 2
    with pytest.raises(ValueError, match="no trial in states .* matches 'P2\\*'"):
        plan_reprocess(db, tmp_path, TrialSelection.parse("P2*"), [parse_method("dlt")])
    os.unlink(tmp_path / "trials" / "trial-00" / "recording.mcap")
    plan = plan_reprocess(db, tmp_path, TrialSelection(), [parse_method("dlt")])
    assert plan.missing == ("trial-00",) and len(plan.tasks) == 1
    (tmp_path / "trials" / "trial-01" / "recording.mcap").write_bytes(b"not an mcap")
    with Inline().open() as ex:
        summary = run_plan(plan, ex)
    assert summary.failed == 1
    [r] = list_results(db)
    assert r.status == "failed" and r.error
    assert plan_reprocess(db, tmp_path, TrialSelection(), [parse_method("dlt")]).tasks == ()
    assert len(plan_reprocess(db, tmp_path, TrialSelection(), [parse_method("dlt")], retry_failed=True).tasks) == 1


def test_fits_ask_the_cluster_for_gpus_triangulations_do_not(tmp_path):
    from gaitcap.services.research.reprocess import ReprocessTask, TrialRef, task_resources

    trial = TrialRef("t1", tmp_path / "recording.mcap")
    resources = task_resources(1.0)
    asks = {m: resources(ReprocessTask("sqlite:///x", trial, parse_method(m))) for m in ("robust", "dlt", "implicit",
                                                                                         "explicit@paper")}
    assert {m: (r.num_cpus, r.num_gpus) for m, r in asks.items()} == {
        "robust": (1.0, 0.0), "dlt": (1.0, 0.0), "implicit": (1.0, 1.0), "explicit@paper": (1.0, 1.0)}
    assert task_resources(0.0)(ReprocessTask("sqlite:///x", trial, parse_method("implicit"))).num_gpus == 0.0
