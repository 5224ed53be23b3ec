"""Result routes: gait JSON, steps CSV, trajectory JSON/CSV/TRC, report PNG, recording; audit of downloads."""

import numpy as np
import pytest
from gaitcap.services import catalog as cat
from gaitcap.services.processing.artifacts import trial_files


@pytest.fixture
def done_trial(server):
    srv, client, _, settings = server
    tid = client.post("/trials", json={"subject_id": "P7"}).json()["id"]
    client.post(f"/trials/{tid}/stop")
    db = cat.open_catalog(settings.catalog_url)
    files = trial_files(settings.data_dir, tid)
    files.recording.write_bytes(b"\x89MCAP0\r\n fake")
    steps = [{"side": "left", "time_s": 1.0, "step_length_mm": 601.5}, {"side": "right", "time_s": 1.6, "step_length_mm": 598.0}]
    cat.store_result(db, trial_id=tid, stage="preliminary", method="robust_triangulation", steps=steps,
                     summary={"step_length_mm": {"mean": 599.75, "sd": 2.5, "unit": "mm"}}, quality={"gc_10": 0.97})
    path = files.stage_file("preliminary", "trajectory_npz")
    path.parent.mkdir(parents=True)
    np.savez(path, points_mm=np.arange(2 * 2 * 3, dtype=float).reshape(2, 2, 3), times_s=np.array([0.0, 1 / 30]),
             joint_names=np.array(["left_heel", "right_heel"]))
    files.stage_file("preliminary", "trajectory_trc").write_text("PathFileType\t4\t(X/Y/Z)\tx.trc\n")
    files.stage_file("preliminary", "report_png").write_bytes(b"\x89PNG\r\n\x1a\n")
    return client, tid


def test_gait_and_steps(done_trial):
    client, tid = done_trial
    g = client.get(f"/trials/{tid}/gait").json()
    assert g["stage"] == "preliminary" and g["summary"]["step_length_mm"]["mean"] == 599.75
    assert g["quality"] == {"gc_10": 0.97} and len(g["steps"]) == 2
    assert client.get(f"/trials/{tid}/gait", params={"stage": "refined"}).status_code == 404
    assert "stage" in client.get(f"/trials/{tid}/gait", params={"stage": "final"}).json()["detail"]
    csv = client.get(f"/trials/{tid}/steps", params={"format": "csv"})
    assert csv.headers["content-type"].startswith("text/csv")
    assert csv.text.splitlines() == ["side,time_s,step_length_mm", "left,1.0,601.5", "right,1.6,598.0"]
    assert client.get(f"/trials/{tid}/steps").json()["steps"][0]["side"] == "left"


def test_trajectory_formats_and_files(done_trial, server):
    client, tid = done_trial
    j = client.get(f"/trials/{tid}/trajectory").json()
    assert j["joint_names"] == ["left_heel", "right_heel"] and j["points_mm"][1][1] == [9.0, 10.0, 11.0]
    lines = client.get(f"/trials/{tid}/trajectory", params={"format": "csv"}).text.splitlines()
    assert lines[0].startswith("time_s,left_heel_x_mm") and lines[2].startswith("0.033,6.000")
    assert client.get(f"/trials/{tid}/trajectory", params={"format": "trc"}).text.startswith("PathFileType")
    assert client.get(f"/trials/{tid}/report.png").content.startswith(b"\x89PNG")
    assert client.get(f"/trials/{tid}/rerun.rrd").status_code == 404
    assert client.get(f"/trials/{tid}/results.mcap").status_code == 404
    files = trial_files(server[3].data_dir, tid)
    files.stage_file("preliminary", "results_mcap").write_bytes(b"\x89MCAP0\r\n results")
    got = client.get(f"/trials/{tid}/results.mcap")
    assert got.content.endswith(b"results") and f"{tid}-preliminary-results.mcap" in got.headers["content-disposition"]
    assert client.get(f"/trials/{tid}/recording").content.startswith(b"\x89MCAP")
    downloads = [e["detail"] for e in client.get("/audit", params={"trial_id": tid}).json() if e["action"] == "download"]
    assert "recording" in downloads and "trajectory preliminary csv" in downloads


def test_recording_of_a_running_trial_is_409(server):
    _, client, _, _ = server
    tid = client.post("/trials", json={"subject_id": "P8"}).json()["id"]
    assert client.get(f"/trials/{tid}/recording").status_code == 409
    assert "no results" in client.get(f"/trials/{tid}/gait").json()["detail"]
