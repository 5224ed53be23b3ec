"""Faults with the whole stack running as real processes: a worker killed mid-fit (its job is re-run
after the lease), the API restarted mid-trial (state recovered from the catalog), two clients pressing
Start at once (one 409)."""

import concurrent.futures
import time

import httpx
import pytest

from services import catalog as cat
from tests.stack_helpers import TOKEN, running_stack


@pytest.fixture(scope="module")
def stack(tmp_path_factory):
    with running_stack(tmp_path_factory.mktemp("faults")) as s:
        yield s


def _client(stack) -> httpx.Client:
    return httpx.Client(base_url=stack.cfg.url, headers={"Authorization": f"Bearer {TOKEN}"}, timeout=30)


def _wait(predicate, timeout_s: float, what: str, poll_s: float = 0.2):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(poll_s)
    raise AssertionError(f"timed out waiting for {what() if callable(what) else what}")


def _trial(c, tid) -> dict:
    return c.get(f"/trials/{tid}").json()


def test_two_clients_pressing_start_at_once_get_one_409(stack):
    def press(i):
        with _client(stack) as c:
            return c.post("/trials", json={"subject_id": f"P{i}"})

    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        replies = list(pool.map(press, range(2)))
    assert sorted(r.status_code for r in replies) == [201, 409]
    tid = next(r.json()["id"] for r in replies if r.status_code == 201)
    with _client(stack) as c:
        time.sleep(1)
        assert c.post(f"/trials/{tid}/stop").status_code == 200
        assert c.post("/trials", json={"subject_id": "P3"}).status_code == 201  # free again after Stop
        assert c.post(f"/trials/{c.get('/trials').json()[0]['id']}/stop").status_code == 200


def test_api_restarted_mid_trial_recovers_state_from_the_catalog(stack):
    with _client(stack) as c:
        tid = c.post("/trials", json={"subject_id": "P0100"}).json()["id"]
    stack.supervisor.restart("api")
    with _client(stack) as c:
        _wait(lambda: _healthy(c), 60, "the API to come back")
        trial = _trial(c, tid)
        assert trial["state"] == "recording"
        assert c.post("/trials", json={"subject_id": "P0101"}).status_code == 409  # still the recording one
        time.sleep(3)
        assert c.post(f"/trials/{tid}/stop").json()["state"] == "recorded"
        trial = _wait(lambda: (t := _trial(c, tid))["results"] or t["state"] == "failed" and t, 120, "results")
        assert "preliminary" in _trial(c, tid)["results"], trial


def test_worker_killed_mid_fit_job_is_rerun(stack):
    db = cat.open_catalog(stack.cfg.catalog)
    with _client(stack) as c:
        tid = c.post("/trials", json={"subject_id": "P0200"}).json()["id"]
        time.sleep(6)
        c.post(f"/trials/{tid}/stop")
        _wait(lambda: _trial(c, tid)["stage"].startswith("refining"), 60,
              lambda: f"the refined fit to start: {_trial(c, tid)}\n{stack.supervisor.log_text('worker-0')[-2000:]}",
              poll_s=0.05)
        before = stack.supervisor.restarts("worker-0")
        stack.supervisor.kill("worker-0")
        _wait(lambda: stack.supervisor.restarts("worker-0") == before + 1, 10, "the supervisor to restart the worker")
        trial = _wait(lambda: (t := _trial(c, tid))["state"] in ("done", "failed") and t, 180, "the re-run")
    assert trial["state"] == "done", trial["error"]
    jobs = cat.jobs_for_trial(db, tid)
    assert [(j.state, j.attempts) for j in jobs] == [("done", 2)]
    assert "refined" in trial["results"]
    db.close()


def _healthy(c) -> bool:
    try:
        return c.get("/health").status_code == 200
    except httpx.HTTPError:
        return False
