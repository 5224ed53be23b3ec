"""Reads never wait on writes: a real worker process stopped (SIGSTOP) inside a catalog write transaction,
holding SQLite's write lock, does not delay the page. Every GET route declared in api/ answers within 1 s
(the audit row of a read goes to the API's audit queue, written once the lock is free), and the queued
audit rows are written after the worker goes on."""

import os
import re
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from gaitcap.services import catalog as cat
from gaitcap.services.catalog.db import STOP_IN_WRITE_ENV
from gaitcap.services.processing.artifacts import trial_files

ROOT = Path(__file__).resolve().parents[2]
GET = re.compile(r"@router\.get\(\s*\"([^\"]+)\"")
READ_LIMIT_S = 1.0


def get_routes() -> list[str]:
    """Every GET route path declared in api/ (as tests/test_docs.py finds them)."""
    return sorted({p for f in (ROOT / "api").rglob("*.py") for p in GET.findall(f.read_text())})


def _proc_state(pid: int) -> str:
    return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]


def _write_locked(path: Path) -> bool:
    con = sqlite3.connect(path, timeout=0.1, isolation_level=None)
    try:
        con.execute("BEGIN IMMEDIATE")
        con.execute("ROLLBACK")
        return False
    except sqlite3.OperationalError as exc:
        return "locked" in str(exc)
    finally:
        con.close()


def _done_trial(client, settings) -> str:
    tid = client.post("/trials", json={"subject_id": "P7"}).json()["id"]
    client.post(f"/trials/{tid}/stop")
    db = cat.open_catalog(settings.catalog_url)
    files = trial_files(settings.data_dir, tid)
    files.recording.write_bytes(b"\x89MCAP0\r\n fake")
    cat.store_result(db, trial_id=tid, stage="preliminary", method="robust_triangulation",
                     steps=[{"side": "left", "time_s": 1.0, "step_length_mm": 601.5}],
                     summary={"step_length_mm": {"mean": 601.5, "sd": 0.0, "unit": "mm"}}, quality={"gc_10": 0.97})
    path = files.stage_file("preliminary", "trajectory_npz")
    path.parent.mkdir(parents=True)
    np.savez(path, points_mm=np.zeros((2, 2, 3)), times_s=np.array([0.0, 1 / 30]),
             joint_names=np.array(["left_heel", "right_heel"]))
    files.stage_file("preliminary", "report_png").write_bytes(b"\x89PNG\r\n\x1a\n")
    db.close()
    return tid


def _url(path: str, tid: str, cal_id: str) -> str:
    values = {"trial_id": tid, "cal_id": cal_id, "name": "cam0", "subject_id": "P7", "camera": "cam0"}
    return re.sub(r"\{(\w+)\}", lambda m: values[m.group(1)], path)


def _timed_get(client, url: str) -> tuple[float, int]:
    t0 = time.monotonic()
    with client.stream("GET", url, params={"frame": 0} if "still" in url else None) as r:  # a stream: headers only
        return time.monotonic() - t0, r.status_code


def test_every_read_route_answers_within_1_s_with_the_worker_stopped_inside_a_write(server, tmp_path):
    _, client, _, settings = server
    tid = _done_trial(client, settings)
    db = cat.open_catalog(settings.catalog_url)
    cal_id = cat.add_calibration(db, toml="[cam0]\nname = 'cam0'\n")
    db.close()
    catalog = Path(settings.catalog_url)
    for path in get_routes():  # once unlocked first: a route's first call imports its modules (s on a loaded machine)
        _timed_get(client, _url(path, tid, cal_id))
    env = {**os.environ, STOP_IN_WRITE_ENV: "3"}  # 1, 2: opening the catalog; 3: its first poll for a job
    worker = subprocess.Popen(
        [sys.executable, "-c", "from gaitcap.services.cli import main; main()", "worker", "--no-bus", "--no-warm-up",
         "--data-dir", str(settings.data_dir), "--catalog", str(catalog)],
        env=env, stdout=subprocess.DEVNULL, stderr=(tmp_path / "worker.log").open("w"))
    try:
        deadline = time.monotonic() + 90
        while _proc_state(worker.pid) != "T":
            assert worker.poll() is None, (tmp_path / "worker.log").read_text()[-2000:]
            assert time.monotonic() < deadline, "the worker never stopped inside a write"
            time.sleep(0.1)
        assert _write_locked(catalog), "the stopped worker holds no write lock"
        slow = {}
        for path in get_routes():
            took, code = _timed_get(client, _url(path, tid, cal_id))
            assert code != 500, path
            if took >= READ_LIMIT_S:
                slow[path] = round(took, 2)
        assert len(get_routes()) >= 25
        assert not slow, f"read routes that waited for the stopped worker: {slow}"
        assert _write_locked(catalog)  # still stopped, still holding it: the reads did not go around it
        os.kill(worker.pid, signal.SIGCONT)
        db = cat.open_catalog(catalog)
        deadline = time.monotonic() + 30
        while not any(e.action == "view" for e in cat.audit_entries(db, trial_id=tid)):
            assert time.monotonic() < deadline, "the queued audit rows were never written"
            time.sleep(0.2)
        db.close()
    finally:
        os.kill(worker.pid, signal.SIGCONT)
        worker.terminate()
        try:
            worker.wait(15)
        except subprocess.TimeoutExpired:
            worker.kill()
            worker.wait()


@pytest.mark.parametrize("value", ["x", "-1"])
def test_the_stop_hook_refuses_a_value_that_is_not_a_count(monkeypatch, tmp_path, value):
    monkeypatch.setenv(STOP_IN_WRITE_ENV, value)
    with pytest.raises(ValueError, match=STOP_IN_WRITE_ENV):
        cat.open_catalog(tmp_path / "c.sqlite")
