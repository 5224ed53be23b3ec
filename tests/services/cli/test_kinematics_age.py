"""``gaitcap kinematics --age``: without a catalog the patient's age chooses the normal-gait band, and
the command says which band it used (text, JSON and kinematics.json alike)."""

import json

import numpy as np
import pytest
from gaitcap.services.kinematics import KinematicsUnavailable, get_engine

pytest.importorskip("opensim", reason="the kinematics extra (opensim) is not installed")


@pytest.fixture(scope="module")
def walk_npz(tmp_path_factory):
    try:
        get_engine()
    except KinematicsUnavailable as exc:
        pytest.skip(f"OpenSim setup files not installed: {exc}")
    from gaitcap.reconstruction.skeletons import get_skeleton
    from gaitcap.simulator.params import WalkParams
    from gaitcap.simulator.path import Room, plan_walk
    from gaitcap.simulator.walker import simulate_body

    params, times = WalkParams(), np.arange(60) / 30.0  # 2 s: the band does not need gait cycles
    points = simulate_body(plan_walk(params, 8.0, Room(), seed=1), params, times)
    npz = tmp_path_factory.mktemp("walk") / "walk.npz"
    np.savez(npz, points_mm=points, times_s=times, joint_names=np.array(get_skeleton("halpe26").joint_names))
    return npz


def test_age_chooses_the_band_and_the_command_names_it(walk_npz, tmp_path):
    from gaitcap.services.cli import app
    from typer.testing import CliRunner

    runner = CliRunner()
    res = runner.invoke(app, ["kinematics", str(walk_npz), "--age", "40", "--out", str(tmp_path / "adult")])
    assert res.exit_code == 0, res.output
    assert "normal-gait band: adults (patient 40 years)" in res.output
    written = json.loads((tmp_path / "adult" / "kinematics.json").read_text())["norms"]
    assert written["population"] == "adults (patient 40 years)" and "knee_flexion" in written["bands"]
    assert "hip_adduction" in written["missing"]  # no adult frontal band: said, not the children's
    res = runner.invoke(app, ["kinematics", str(walk_npz), "--age", "40", "--json", "--out", str(tmp_path / "j")])
    assert res.exit_code == 0 and json.loads(res.stdout)["norms"] == written  # what is shown is what is written
    res = runner.invoke(app, ["kinematics", str(walk_npz), "--age", "200"])
    assert res.exit_code == 2 and "--age: must be in [0, 120] years, got 200" in res.output
