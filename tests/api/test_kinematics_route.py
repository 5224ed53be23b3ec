"""GET /trials/{id}/kinematics: the report as JSON and CSV, the model files, and a clear 404 without them."""

import json

import numpy as np
import pytest
from gaitcap.services import catalog as cat
from gaitcap.services.processing.artifacts import trial_files


@pytest.fixture(scope="module")
def synthetic_walk():
    """6 s of the synthetic walker (exact keypoints) and its gait report's steps."""
    from gaitcap.reconstruction.gait import analyze_gait
    from gaitcap.reconstruction.skeletons import get_skeleton
    from gaitcap.simulator.params import WalkParams
    from gaitcap.simulator.path import Room, plan_walk
    from gaitcap.simulator.walker import simulate_body

    params, times = WalkParams(), np.arange(180) / 30.0
    points = simulate_body(plan_walk(params, 6.0, Room(), seed=0), params, times)
    names = get_skeleton("halpe26").joint_names
    return points, times, names, analyze_gait(points, times, list(names)).steps


@pytest.fixture
def trial_with_result(server):
    srv, client, _, settings = server
    tid = client.post("/trials", json={"subject_id": "P8"}).json()["id"]
    client.post(f"/trials/{tid}/stop")
    db = cat.open_catalog(settings.catalog_url)
    cat.store_result(db, trial_id=tid, stage="preliminary", method="robust_triangulation", steps=[],
                     summary={}, quality={})
    return client, tid, trial_files(settings.data_dir, tid)


def test_no_kinematics_is_a_404_naming_why(trial_with_result):
    client, tid, files = trial_with_result
    r = client.get(f"/trials/{tid}/kinematics")
    assert r.status_code == 404 and "kinematics" in r.json()["detail"]
    folder = files.stage_file("preliminary", "kinematics_json").parent
    folder.mkdir(parents=True)
    files.stage_file("preliminary", "kinematics_json").write_text(
        json.dumps({"available": False, "reason": "the 'opensim' package is not installed"}))
    body = client.get(f"/trials/{tid}/kinematics").json()
    assert body["available"] is False and "opensim" in body["reason"]
    r = client.get(f"/trials/{tid}/kinematics", params={"format": "mot"})
    assert r.status_code == 404 and "opensim" in r.json()["detail"]
    assert client.get(f"/trials/{tid}/kinematics", params={"format": "xls"}).status_code == 422


def test_kinematics_json_csv_and_files(trial_with_result, synthetic_walk):
    pytest.importorskip("opensim", reason="the kinematics extra (opensim) is not installed")
    from gaitcap.services.kinematics.files import setup_dir
    from gaitcap.services.kinematics.trial import trial_kinematics

    if not (setup_dir() / "Model_Pose2Sim_simple.osim").is_file():
        pytest.skip("OpenSim model not installed (deploy/bootstrap.sh)")
    client, tid, files = trial_with_result
    points, times, names, steps = synthetic_walk
    trial_kinematics(points, times, names, steps=steps,
                     out_dir=files.stage_file("preliminary", "kinematics_json").parent)
    body = client.get(f"/trials/{tid}/kinematics").json()
    assert body["available"] and body["stage"] == "preliminary"
    knee = body["curves"]["knee_flexion"]["right"]
    assert knee["n_cycles"] >= 1 and len(knee["mean_deg"]) == 101
    assert 40 < max(knee["mean_deg"]) < 80
    assert body["marker_errors_mm"]["RKnee"]["rms"] < 30
    csv = client.get(f"/trials/{tid}/kinematics", params={"format": "csv"})
    assert csv.headers["content-type"].startswith("text/csv")
    header = csv.text.splitlines()[0].split(",")
    assert header[:2] == ["percent", "pelvis_obliquity_left_mean_deg"] and "knee_flexion_right_mean_deg" in header
    assert not any(c.startswith("pelvis_tilt") for c in header)  # held by the fit, not measured
    assert "pelvis_tilt" in body["not_measured"]
    assert len(csv.text.splitlines()) == 102
    png = client.get(f"/trials/{tid}/kinematics", params={"format": "png"})
    assert png.headers["content-type"] == "image/png" and png.content.startswith(b"\x89PNG")
    mot = client.get(f"/trials/{tid}/kinematics", params={"format": "mot"})
    assert "endheader" in mot.text and "knee_angle_r" in mot.text
    c3d = client.get(f"/trials/{tid}/kinematics", params={"format": "c3d"})
    assert c3d.status_code == 200 and len(c3d.content) > 1000
    assert "<OpenSimDocument" in client.get(f"/trials/{tid}/kinematics", params={"format": "osim"}).text
    trc = client.get(f"/trials/{tid}/kinematics", params={"format": "trc"}).text.splitlines()
    assert trc[2].split("\t")[4] == "m" and "RKnee" in trc[3]
