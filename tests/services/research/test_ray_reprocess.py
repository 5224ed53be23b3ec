"""A sweep on a local Ray cluster (2 CPUs): 3 simulated trials x 2 methods, one Ray worker SIGKILLed in the
middle of a task; nothing is lost, nothing is duplicated, and the results equal the local pool's."""

import os
import signal
import threading
import time

import pytest
import ray  # a dev dependency: without it this test fails rather than skips
from gaitcap.services.catalog.method_results import list_results
from gaitcap.services.cli import app
from gaitcap.services.research.executors import LocalPool, RayCluster
from gaitcap.services.research.reprocess import TrialSelection, plan_reprocess, run_plan
from gaitcap.services.research.sweep import summarize
from typer.testing import CliRunner

from .reprocess_trials import make_walks, recorded_catalog


def _ray_task_pids() -> list[int]:
    """Ray workers busy with a reprocess task (Ray titles them ``ray::run_task``)."""
    out = []
    for pid in os.listdir("/proc"):
        try:
            if pid.isdigit() and open(f"/proc/{pid}/cmdline", "rb").read().startswith(b"ray::run_task"):
                out.append(int(pid))
        except OSError:
            pass
    return out


@pytest.fixture
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, configure_logging=False)
    try:
        yield
    finally:
        ray.shutdown()


def test_ray_sweep_survives_a_killed_worker_and_matches_the_local_pool(tmp_path, local_ray):
    from gaitcap.services.research.method_specs import parse_method

    walks = make_walks(3)
    specs = [parse_method("robust"), parse_method("dlt")]
    db, ids = recorded_catalog(tmp_path / "ray", walks)
    plan = plan_reprocess(db, tmp_path / "ray", TrialSelection(), specs)
    assert len(plan.tasks) == 6
    box, killed = {}, []

    def run() -> None:
        with RayCluster(max_retries=3).open() as ex:
            box["summary"] = run_plan(plan, ex)

    thread = threading.Thread(target=run)
    thread.start()
    deadline = time.monotonic() + 120
    while not killed and time.monotonic() < deadline and thread.is_alive():
        busy = _ray_task_pids()
        if busy and len(list_results(db)) < 3:
            time.sleep(0.3)
            os.kill(busy[0], signal.SIGKILL)
            killed.append(busy[0])
        time.sleep(0.05)
    thread.join(300)
    assert killed and not thread.is_alive(), "a Ray worker should have been killed mid-sweep"
    assert box["summary"].computed == 6 and box["summary"].failed == 0
    on_ray = list_results(db)
    assert len(on_ray) == 6 and len({(r.trial_id, r.method, r.params_key) for r in on_ray}) == 6
    assert all(r.ok for r in on_ray)

    pool_db, _ = recorded_catalog(tmp_path / "pool", walks)
    with LocalPool(workers=2).open() as ex:
        run_plan(plan_reprocess(pool_db, tmp_path / "pool", TrialSelection(), specs), ex)
    by_key = {(r.trial_id, r.params_key): r.comparable() for r in list_results(pool_db)}
    assert {(r.trial_id, r.params_key): r.comparable() for r in on_ray} == by_key

    table = summarize(db, ids, specs)
    assert [row["trials"] for row in table.rows] == [3, 3]
    robust, dlt = table.rows
    assert robust["GC_10"] > dlt["GC_10"] and robust["MPJPE"] < dlt["MPJPE"]

    # the command line on the same (already running) Ray: only the new method's pairs are computed
    result = CliRunner().invoke(app, ["reprocess", "--data-dir", str(tmp_path / "ray"), "--ray", "auto",
                                      "-m", "robust", "-m", "robust:sigma_mm=100", "--json"])
    assert result.exit_code == 0, result.output
    assert '"computed": 3, "skipped": 3, "failed": 0' in result.output
    assert len(list_results(db)) == 9
